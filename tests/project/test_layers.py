"""Each module imports only from its own or lower layers, and no imports go round in a cycle.

Imports are import statements and ``importlib.import_module`` calls, so a
package scan that loops back is a cycle too.

The layers are those of the Layout section of docs/architecture.md.
"""

import ast
import re
from pathlib import Path

import vptoolkit

LAYERS = {
    "errors": 0, "conventions": 0, "optional": 0, "checks": 0, "files": 0, "progress": 0,
    "parallel": 0, "_numba": 0, "_version": 0,
    "mesh": 1, "point_cloud": 1, "appearance": 1, "io": 1, "samples": 1, "predictions": 4,
    "geometry": 2, "sphere": 2, "camera": 2, "rotations": 2, "settings": 2, "upright": 2,
    "point_areas": 2, "cloud_sample": 2,
    "visibility": 3,
    "measures": 4, "view_sets": 4,
    "clean": 5, "points": 5, "point_features": 5, "_face_location": 5,
    "scan": 5,
    "dataset": 6, "data": 7, "inputs": 7, "dataset_card": 0,
    "synthetic": 5, "learn": 8, "evaluate": 9, "best_view": 9, "predictors": 9,
    "collection": 9,
    "pictures": 10,
    "cli": 99,
}
PACKAGE = Path(vptoolkit.__file__).parent


def top_module(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return "__init__" if parts == ("__init__",) else parts[0]


def imported_modules(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return {n.split(".")[1] for n in names if n.startswith("vptoolkit.")}


def test_every_module_is_in_the_layer_map():
    modules = {top_module(p) for p in PACKAGE.rglob("*.py")} - {"__init__"}
    assert modules <= set(LAYERS), sorted(modules - set(LAYERS))


def test_no_module_imports_from_a_higher_layer():
    violations = []
    for path in sorted(PACKAGE.rglob("*.py")):
        own = top_module(path)
        if own == "__init__":
            continue
        for target in imported_modules(path):
            if LAYERS.get(target, 99) > LAYERS[own]:
                violations.append(f"{path.relative_to(PACKAGE)} imports vptoolkit.{target}")
    assert not violations, violations


DATASET_STAGES = {"store": {"store"}, "builder": {"store", "builder"},
                  "release": {"store", "release"}, "authors": {"store", "builder", "authors"}}
"""Which stages of ``vptoolkit.dataset`` each stage may import (its own and those below)."""


def test_dataset_stages_import_only_lower_stages():
    violations = []
    assert {p.name for p in (PACKAGE / "dataset").iterdir() if p.is_dir()} - {"__pycache__"} \
        == set(DATASET_STAGES)
    for stage, allowed in DATASET_STAGES.items():
        for path in sorted((PACKAGE / "dataset" / stage).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ImportFrom) and node.module:
                    parts = node.module.split(".")
                    if parts[:2] == ["vptoolkit", "dataset"] and len(parts) > 2 \
                            and parts[2] not in allowed:
                        violations.append(f"{path.relative_to(PACKAGE)} imports {node.module}")
    assert not violations, violations


SKIPPED_FOLDERS = {"build", "dist", "venv", "node_modules"}
"""Folder names that pytest, ruff and packaging tools pass over by default."""


def test_no_source_folder_has_a_name_tools_skip():
    # tests and lint would silently miss a package, test or tool folder of such a name
    named = [str(path.relative_to(PACKAGE.parent)) for top in ("vptoolkit", "tests", "tools")
             for path in (PACKAGE.parent / top).rglob("*")
             if path.is_dir() and path.name in SKIPPED_FOLDERS]
    assert not named, named


def module_name(path: Path) -> str:
    parts = ("vptoolkit", *path.relative_to(PACKAGE).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}

def module_level_nodes(tree: ast.Module) -> list[ast.AST]:
    """Statements run at import: the module body, into if/try/with blocks, not into defs."""
    found: list[ast.AST] = []
    pending: list[ast.AST] = list(tree.body)
    while pending:
        node = pending.pop()
        found.append(node)
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            pending.extend(ast.iter_child_nodes(node))
    return found


def module_aliases(tree: ast.Module) -> dict[str, str]:
    """Local names bound to package modules by the imports of a module (``catalog``:
    ``vptoolkit.measures.catalog``)."""
    aliases = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                if full in MODULES:
                    aliases[alias.asname or alias.name] = full
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname and alias.name in MODULES:
                    aliases[alias.asname] = alias.name
    return aliases


def import_module_targets(node: ast.AST, aliases: dict[str, str]) -> set[str]:
    """The package modules an ``importlib.import_module(...)`` call may import.

    A constant name is followed as it is; a name built as ``f"{package.__name__}.{...}"``
    (a scan of a package) may import every module of that package.
    """
    if not (isinstance(node, ast.Call) and node.args
            and (isinstance(node.func, ast.Attribute) and node.func.attr == "import_module"
                 or isinstance(node.func, ast.Name) and node.func.id == "import_module")):
        return set()
    name = node.args[0]
    if isinstance(name, ast.Constant) and isinstance(name.value, str):
        return {name.value}
    if isinstance(name, ast.JoinedStr) and name.values:
        first = name.values[0]
        if (isinstance(first, ast.FormattedValue) and isinstance(first.value, ast.Attribute)
                and first.value.attr == "__name__" and isinstance(first.value.value, ast.Name)
                and first.value.value.id in aliases):
            package = aliases[first.value.value.id]
            return {module for module in MODULES if module.startswith(f"{package}.")}
    return set()


def import_graph(*, module_level_only: bool) -> dict[str, set[str]]:
    """Each package module and the package modules it imports (full dotted names), through
    import statements and ``importlib.import_module`` calls."""
    graph = {}
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text())
        nodes = module_level_nodes(tree) if module_level_only else list(ast.walk(tree))
        aliases = module_aliases(tree)
        targets = set()
        for node in nodes:
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets.add(node.module)
                targets.update(f"{node.module}.{alias.name}" for alias in node.names)
            elif isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            targets |= import_module_targets(node, aliases)
        graph[name] = {target for target in targets if target in MODULES} - {name}
    return graph


def test_import_module_calls_are_followed():
    scan = ast.parse("import importlib\n"
                     "from vptoolkit.measures import catalog\n"
                     "def every():\n"
                     "    for name in ('ve', 'vr'):\n"
                     "        importlib.import_module(f'{catalog.__name__}.{name}')\n"
                     "    import vptoolkit.view_sets as sets\n"
                     "    importlib.import_module(f'{sets.__name__}.search')\n"
                     "    importlib.import_module('vptoolkit.sphere')\n")
    aliases = module_aliases(scan)
    found = set().union(*(import_module_targets(node, aliases) for node in ast.walk(scan)))
    assert {"vptoolkit.measures.catalog.ve", "vptoolkit.view_sets.search",
            "vptoolkit.sphere"} <= found
    assert "vptoolkit.measures.registry" not in found


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle per back edge found by a depth-first walk, e.g. ``[a, b, a]``."""
    found: list[list[str]] = []
    state: dict[str, str] = {}
    path: list[str] = []

    def visit(module: str) -> None:
        state[module] = "open"
        path.append(module)
        for target in sorted(graph[module]):
            if state.get(target) == "open":
                found.append([*path[path.index(target):], target])
            elif target not in state:
                visit(target)
        path.pop()
        state[module] = "done"

    for module in sorted(graph):
        if module not in state:
            visit(module)
    return found


def test_cycles_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b", "a"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_at_module_level():
    found = cycles(import_graph(module_level_only=True))
    assert not found, [" -> ".join(cycle) for cycle in found]


def test_no_import_cycle_through_imports_inside_functions():
    found = cycles(import_graph(module_level_only=False))
    assert not found, [" -> ".join(cycle) for cycle in found]


MODULE_LINES = 600
"""A module over this many lines must say in its docstring why it stays whole."""


def test_long_modules_say_why_they_are_not_split():
    unexplained = []
    for path in sorted(PACKAGE.rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        if source.count("\n") <= MODULE_LINES:
            continue
        docstring = ast.get_docstring(ast.parse(source)) or ""
        if not re.search(r"^Size\b", docstring, flags=re.MULTILINE):
            unexplained.append(f"{path.relative_to(PACKAGE)} ({source.count(chr(10))} lines)")
    assert not unexplained, (f"over {MODULE_LINES} lines without a 'Size' paragraph in the "
                             f"docstring: {', '.join(unexplained)}")


def test_names_are_exported_only_by_the_module_that_defines_them():
    # docs/architecture.md, "Package faces": vptoolkit itself is the one face.
    re_exported = []
    for name, path in MODULES.items():
        if name == "vptoolkit":
            continue
        tree = ast.parse(path.read_text())
        imported = {alias.asname or alias.name for node in tree.body
                    if isinstance(node, ast.ImportFrom) for alias in node.names}
        for node in tree.body:
            if (isinstance(node, ast.Assign)
                    and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets)):
                exported = [ast.literal_eval(element) for element in node.value.elts]
                re_exported += [f"{name}.{item}" for item in exported if item in imported]
    assert not re_exported, f"__all__ lists imported names: {', '.join(re_exported)}"


def test_no_module_re_exports_a_name_as_itself():
    # "from m import X as X" (and "import X as X") is the re-export form of type checkers:
    # a face that __all__ does not show. vptoolkit itself, the one face, uses __all__.
    re_exported = [f"{name}: {alias.name} as {alias.asname}" for name, path in MODULES.items()
                   for node in ast.walk(ast.parse(path.read_text()))
                   if isinstance(node, (ast.Import, ast.ImportFrom))
                   for alias in node.names if alias.asname == alias.name]
    assert not re_exported, f"names re-exported as themselves: {', '.join(re_exported)}"


def _defined_names(tree: ast.Module) -> set[str]:
    """Names a module defines at import: functions, classes and assigned names."""
    names = set()
    for node in module_level_nodes(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(name.id for target in targets for name in ast.walk(target)
                         if isinstance(name, ast.Name))
    return names


def test_names_are_imported_from_the_module_that_defines_them():
    # No facade inside the package: a name comes from its owner, never through a module
    # that imported it (a submodule of a package counts as the package's own).
    defined = {name: _defined_names(ast.parse(path.read_text())) for name, path in MODULES.items()}
    borrowed = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.ImportFrom) and node.module in MODULES):
                continue
            borrowed += [f"{name}: {alias.name} from {node.module}" for alias in node.names
                         if alias.name not in defined[node.module]
                         and f"{node.module}.{alias.name}" not in MODULES]
    assert not borrowed, borrowed
