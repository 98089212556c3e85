"""What a pack's cases folder may hold: `<RULE>.yaml`/`.yml` case files, a README and hidden
entries. A `PACK.cases` file, a `TP-1.yaml` folder or a stray `notes.txt` were passed over
unsaid (`rules test PACK --own`: exit 0, "0 cases, 0 failed"); each is refused (exit 2) naming
the path and what was expected, as a case file for a rule the pack lacks is."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules.cases import case_files
from casekit import extension_pack as _pack
from casekit import lint_messages as _messages

#: cases of a rule the pack disables: listed, not run (no delivery is built), exit 0
_CP5 = "rule: CP-5\ncases:\n  - name: covered\n    expect: pass\n"


def _disabling_pack(tmp_path: Path) -> tuple[Path, Path]:
    """A pack disabling CP-5 and its cases folder holding CP-5.yaml."""
    pack = _pack(tmp_path, "disable: [CP-5]\n")
    folder = tmp_path / "project.cases"
    folder.mkdir()
    (folder / "CP-5.yaml").write_text(_CP5, "utf-8")
    return pack, folder


def _refused(blockqc, pack: Path) -> str:
    """`rules test PACK --own` and `rules lint PACK` both exit 2: the test's stderr."""
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 2, p.stdout + p.stderr
    assert "Traceback" not in p.stderr and "cases, 0 failed" not in p.stdout
    lint = blockqc("rules", "lint", pack)
    assert lint.returncode == 2 and "Traceback" not in lint.stderr, lint.stdout + lint.stderr
    assert lint.stderr == p.stderr
    return p.stderr


def test_a_cases_file_in_place_of_the_folder_is_refused(blockqc, tmp_path: Path) -> None:
    pack = _pack(tmp_path, "")
    folder = tmp_path / "project.cases"
    folder.write_text(_CP5, "utf-8")
    assert _refused(blockqc, pack) == (
        f"error: {folder}: a file: expected the folder of the pack's cases, holding "
        "<RULE>.yaml files (one per rule)\n"
    )


def test_a_folder_named_like_a_case_file_is_refused(blockqc, tmp_path: Path) -> None:
    pack, folder = _disabling_pack(tmp_path)
    (folder / "TP-1.yaml").mkdir()
    assert _refused(blockqc, pack) == (
        f"error: {folder / 'TP-1.yaml'}: a folder: expected a case file (YAML) for rule TP-1\n"
    )


@pytest.mark.parametrize("name", ["notes.txt", "TP-1.YAML", "CP-5.yaml.bak", "old"])
def test_an_entry_that_is_not_a_case_file_is_refused(blockqc, tmp_path: Path, name: str) -> None:
    pack, folder = _disabling_pack(tmp_path)
    stray = folder / name
    if name == "old":
        stray.mkdir()
    else:
        stray.write_text("what the CP-5 cases are for\n", "utf-8")
    kind = "a folder" if name == "old" else "a file"
    assert _refused(blockqc, pack) == (
        f"error: {stray}: not a case file ({kind}): expected <RULE>.yaml or <RULE>.yml, one per "
        "rule of the pack (beside them only a README is left unread)\n"
    )


def test_every_entry_refused_is_listed(tmp_path: Path) -> None:
    """Two strays and a rule in both .yaml and .yml: three problems at once, in name order."""
    _, folder = _disabling_pack(tmp_path)
    (folder / "CP-5.yml").write_text(_CP5, "utf-8")
    (folder / "a.txt").write_text("", "utf-8")
    (folder / "TP-1.yaml").mkdir()
    with pytest.raises(RuleError) as exc:
        case_files(folder)
    assert [(Path(p.file).name, p.message.split(":")[0]) for p in exc.value.problems] == [
        ("TP-1.yaml", "a folder"),
        ("a.txt", "not a case file (a file)"),
        ("CP-5.yml", "cases for CP-5 also in CP-5.yaml"),
    ]


@pytest.mark.parametrize("readme", ["README.md", "README", "readme.txt"])
def test_a_readme_and_hidden_entries_are_left_unread(blockqc, tmp_path: Path, readme: str) -> None:
    """A README says what the cases are for; `.gitkeep` keeps an empty folder in git: neither
    is an input, and the case files beside them run as before."""
    pack, folder = _disabling_pack(tmp_path)
    (folder / readme).write_text("# Cases of the project pack\n", "utf-8")
    (folder / ".gitkeep").write_text("", "utf-8")
    assert case_files(folder) == [folder / "CP-5.yaml"]
    assert _messages(pack) == []
    p = blockqc("rules", "test", pack, "--own")
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.rstrip().endswith("0 cases, 0 failed, 1 not run (their rule disabled)")


def test_a_pack_without_a_cases_folder_has_no_cases(tmp_path: Path) -> None:
    assert case_files(tmp_path / "project.cases") == []
