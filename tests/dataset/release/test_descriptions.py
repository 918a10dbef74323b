"""update_card: after a person edits the card, croissant.json and SHA256SUMS follow it, and
nothing else may have changed."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from vptoolkit.errors import VerificationError


def test_update_card_rewrites_croissant_and_manifest_only(mini_release_copy: Path) -> None:
    from vptoolkit.dataset.release.descriptions import update_card
    from vptoolkit.dataset.release.manifest import verify

    before = {p.name: p.read_bytes() for p in mini_release_copy.iterdir() if p.is_file()}
    assert update_card(mini_release_copy) == ["croissant.json", "SHA256SUMS"]
    assert before["croissant.json"] == (mini_release_copy / "croissant.json").read_bytes()
    card = mini_release_copy / "README.md"
    text = card.read_text(encoding="utf-8").replace(
        "geometric proxies", "geometric proxies (ask someone@example.org)")
    card.write_text(text, encoding="utf-8")
    assert not verify(mini_release_copy).ok
    update_card(mini_release_copy)
    assert verify(mini_release_copy).ok
    document = json.loads((mini_release_copy / "croissant.json").read_text())
    assert "someone@example.org" in document["rai:dataLimitations"]
    for name, content in before.items():
        if name not in ("README.md", "croissant.json", "SHA256SUMS"):
            assert (mini_release_copy / name).read_bytes() == content, name


def test_update_card_refuses_when_an_archive_changed(mini_release_copy: Path) -> None:
    from vptoolkit.dataset.release.descriptions import update_card

    archive = mini_release_copy / "mini.h5"
    data = bytearray(archive.read_bytes())
    data[-10] ^= 0xFF
    archive.write_bytes(bytes(data))
    with pytest.raises(VerificationError, match="mini.h5: differs from SHA256SUMS"):
        update_card(mini_release_copy)


@pytest.mark.parametrize("croissant", ["[" * 200_000, "[1, 2]"], ids=["nested", "a-list"])
def test_cli_update_card_refuses_a_croissant_it_cannot_read(mini_release_copy: Path,
                                                            croissant: str) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    (mini_release_copy / "croissant.json").write_text(croissant)
    result = CliRunner().invoke(main, ["pack", "--update-card", str(mini_release_copy)])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("vptool: error: croissant.json: ")
    assert result.output.count("\n") == 1 and "Traceback" not in result.output


def _update_card_cli(release_copy: Path):
    from click.testing import CliRunner

    from vptoolkit.cli import main

    return CliRunner().invoke(main, ["pack", "--update-card", str(release_copy)])


def _unchanged(release_copy: Path, before: dict[str, bytes]) -> None:
    for name in ("croissant.json", "SHA256SUMS"):
        assert (release_copy / name).read_bytes() == before[name], name


def _tamper_copied_shard(release_copy: Path) -> None:
    shard = next(iter(sorted((release_copy / "data").glob("*.parquet"))))
    shutil.copy(shard, shard.with_name("extra-00000-of-00001.parquet"))


def _tamper_croissant(release_copy: Path) -> None:
    path = release_copy / "croissant.json"
    document = json.loads(path.read_text(encoding="utf-8"))
    document["license"] = "https://example.org/mine"
    document["name"] = "someone else's"
    path.write_text(json.dumps(document), encoding="utf-8")


def _tamper_card_link(release_copy: Path) -> None:
    card = release_copy / "README.md"
    elsewhere = release_copy.parent / "card-elsewhere.md"
    elsewhere.write_bytes(card.read_bytes() + b"\nedited\n")
    card.unlink()
    card.symlink_to(elsewhere)


@pytest.mark.parametrize(("tamper", "message"), [
    (_tamper_copied_shard, r"data/extra-00000-of-00001.parquet: not listed in SHA256SUMS"),
    (_tamper_croissant, r"croissant.json: differs from SHA256SUMS"),
    (_tamper_card_link, r"README.md: a symbolic link"),
], ids=["unlisted-shard", "edited-croissant", "card-symlink"])
def test_update_card_blesses_only_the_card(mini_release_copy: Path, tamper, message: str) -> None:
    from vptoolkit.dataset.release.manifest import verify

    tamper(mini_release_copy)
    before = {name: (mini_release_copy / name).read_bytes()
              for name in ("croissant.json", "SHA256SUMS")}
    result = _update_card_cli(mini_release_copy)
    assert result.exit_code == 1, result.output
    assert re.search(message, result.output), result.output
    assert result.output.count("\n") == 1 and "Traceback" not in result.output
    _unchanged(mini_release_copy, before)
    report = verify(mini_release_copy)
    assert not report.ok or report.warnings


def test_update_card_puts_croissant_back_when_the_manifest_cannot_be_written(
        mini_release_copy: Path, monkeypatch) -> None:
    from vptoolkit.dataset.release import descriptions

    card = mini_release_copy / "README.md"
    card.write_text(card.read_text(encoding="utf-8") + "\nA correction.\n", encoding="utf-8")
    before = {name: (mini_release_copy / name).read_bytes()
              for name in ("croissant.json", "SHA256SUMS")}
    real = descriptions.write_bytes_atomic

    def failing(path, payload):
        if Path(path).name == "SHA256SUMS":
            raise OSError(28, "No space left on device", str(path))
        return real(path, payload)

    monkeypatch.setattr(descriptions, "write_bytes_atomic", failing)
    with pytest.raises(OSError, match="No space left"):
        descriptions.update_card(mini_release_copy)
    _unchanged(mini_release_copy, before)
    assert [p.name for p in mini_release_copy.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("name", ["README.md", "SHA256SUMS"])
def test_cli_update_card_on_a_file_that_is_not_utf8_is_one_line(mini_release_copy: Path,
                                                                 name: str) -> None:
    path = mini_release_copy / name
    path.write_bytes(path.read_bytes() + b"\xff\xfe latin-1 \xe9\n")
    before = {n: (mini_release_copy / n).read_bytes() for n in ("croissant.json", "SHA256SUMS")}
    result = _update_card_cli(mini_release_copy)
    assert result.exit_code in (1, 2), result.output
    assert f"{name}: not UTF-8 text" in result.output
    assert result.output.count("\n") == 1 and "Traceback" not in result.output
    _unchanged(mini_release_copy, before)


def test_cli_update_card(mini_release_copy: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    result = CliRunner().invoke(main, ["pack", "--update-card", str(mini_release_copy)])
    assert result.exit_code == 0, result.output
    assert "croissant.json, SHA256SUMS" in result.stdout


def test_update_card_refuses_a_card_that_lost_the_heading_of_an_rai_field(
        mini_release_copy: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    card = mini_release_copy / "README.md"
    before = (mini_release_copy / "croissant.json").read_bytes()
    card.write_text(card.read_text(encoding="utf-8").replace("## Uses\n", "## Intended uses\n"),
                    encoding="utf-8")
    result = CliRunner().invoke(main, ["pack", "--update-card", str(mini_release_copy)])
    assert result.exit_code == 2
    assert len(result.output.strip().splitlines()) == 1
    assert "rai:dataUseCases is read from the card's section '## Uses'" in result.output
    assert (mini_release_copy / "croissant.json").read_bytes() == before
