"""Rule packs are code under test: lint of the stock packs, extension without Python."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from blockqc.resources import rules_dir, templates_dir
from blockqc.rules import available_packs, load_pack
from blockqc.rules.lint import lint
from casekit import SAMPLES

#: the one place the contract's twenty stock ids are written out (contract v1)
CONTRACT_IDS = {
    "MB-1",
    "MB-2",
    "MB-3",
    "TP-1",
    "TP-2",
    "TP-3",
    "TP-4",
    "TP-5",
    "RO-1",
    "RO-2",
    "RO-3",
    "RO-4",
    "CP-1",
    "CP-2",
    "CP-3",
    "CP-4",
    "CP-5",
    "DOC-1",
    "DOC-2",
    "DOC-3",
}


def test_resources_found() -> None:
    assert (rules_dir() / "global-project.yaml").is_file()
    assert (templates_dir() / "block.html.j2").is_file()


def test_stock_pack_has_the_contract_rules() -> None:
    pack = load_pack("global-project")
    missing = CONTRACT_IDS - {r.id for r in pack.rules}
    assert not missing, f"the stock pack lacks contract rules {sorted(missing)}"


@pytest.mark.parametrize("name", available_packs())
def test_pack_lint(name: str) -> None:
    """The same lint as `blockqc rules lint`: ids, metrics, scopes, columns, groups, cases."""
    pack, problems = lint(name)
    assert problems == [], "\n".join(map(str, problems))
    assert pack is not None
    for r in pack.rules:
        assert r.description.strip(), f"{r.id} has no description"


def test_ten_line_pack_changes_verdicts(blockqc, tmp_path: Path) -> None:
    pack = SAMPLES / "packs" / "strict-project.yaml"
    assert len(pack.read_text().splitlines()) <= 10
    out_stock, out_strict = tmp_path / "stock", tmp_path / "strict"
    for out, rules in ((out_stock, "global-project"), (out_strict, pack)):
        blockqc(
            "inspect",
            SAMPLES / "batch" / "F2-B01",
            SAMPLES / "batch" / "F1-B01",
            "--rules",
            rules,
            "--out",
            out,
            "--no-pdf",
        )
    stock = json.loads((out_stock / "F2-B01" / "results.json").read_text())
    strict = json.loads((out_strict / "F2-B01" / "results.json").read_text())
    assert stock["verdict"] == "pass" and strict["verdict"] == "fail"
    cp2 = {x["group"]["method"]: x for x in strict["results"] if x["rule"] == "CP-2"}
    assert cp2["high_precision"]["threshold"] == 5.0  # the new plane norm
    assert cp2["high_precision"]["detail"]["bound_m"] == 10.0  # and the gross bound 2·m with it
    cp4 = {
        x["group"]["method"]: x
        for x in strict["results"]
        if x["rule"] == "CP-4" and x["group"]["component"] == "plane"
    }
    # under the 10 m norm no plane checkpoint of field 2 is gross beyond the first one
    assert cp4["high_precision"]["status"] == "fail"
    assert cp4["high_precision"]["detail"]["n_gross"] > 1
    ro2 = next(
        x for x in strict["results"] if x["rule"] == "RO-2" and x["group"]["component"] == "plane"
    )
    assert ro2["threshold"] == 10.0 and ro2["status"] == "fail"  # 2·5 m
    assert not any(x["rule"] == "CP-5" for x in strict["results"])  # disabled
    tp1 = next(x for x in strict["results"] if x["rule"] == "TP-1")
    assert tp1["statistic"] == "rms" and "median" in tp1["detail"]  # the median beside it
    assert strict["rule_pack"] == "strict-project"


def test_override_of_unknown_rule_and_circular_extends(tmp_path: Path) -> None:
    from blockqc.errors import RuleError

    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text("pack: a\nextends: b.yaml\n")
    b.write_text("pack: b\nextends: a.yaml\n")
    with pytest.raises(RuleError, match="closes a circle"):
        load_pack(a)
    c = tmp_path / "c.yaml"
    c.write_text(
        "pack: c\nextends: global-project\noverrides:\n  TP-9: {severity: warn}\ndisable: [XX-1]\n"
    )
    with pytest.raises(RuleError) as err:
        load_pack(c)
    text = str(err.value)
    assert "line 4: overrides.TP-9: no rule TP-9 to override" in text
    assert "disable: no rule XX-1 to disable" in text


def test_rules_cli(blockqc) -> None:
    p = blockqc("rules", "list")
    assert p.returncode == 0 and "RO-3" in p.stdout and "plane: < 28.2843" in p.stdout
    p = blockqc("rules", "explain", "CP-2")
    assert p.returncode == 0 and "checkpoint_accuracy" in p.stdout and "§CP-5" in p.stdout
    p = blockqc("rules", "explain", "XX-1")
    assert p.returncode == 2 and "no rule XX-1" in p.stderr
    p = blockqc("rules", "lint")
    n = len(load_pack("global-project").rules)
    assert p.returncode == 0 and f"global-project: {n} rules, ok" in p.stdout


def test_rule_reference_is_generated_from_the_pack(blockqc) -> None:
    """docs/rules.md is `blockqc rules list --markdown`: regenerate it when the pack changes."""
    p = blockqc("rules", "list", "--markdown")
    doc = Path(__file__).resolve().parents[1] / "docs" / "rules.md"
    assert p.stdout == doc.read_text(), "docs/rules.md is stale: blockqc rules list --markdown"
