"""Each module imports only from its own or lower layers (see STYLE.md's package map)."""

import ast
from pathlib import Path

import vptoolkit

LAYERS = {
    "errors": 0, "conventions": 0, "optional": 0, "checks": 0, "files": 0,
    "mesh": 1, "io": 1, "samples": 1,
    "geometry": 2, "sphere": 2, "camera": 2, "rotations": 2,
    "visibility": 3,
    "measures": 4, "view_sets": 4,
    "clean": 5, "points": 5,
    "dataset": 6, "data": 7, "dataset_card": 0,
    "synthetic": 5, "learn": 8, "evaluate": 9, "protocol": 9,
    "render": 10, "sphere_map": 10, "report": 10, "thumbnails": 10, "software_render": 10,
    "contact_sheet": 10,
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
