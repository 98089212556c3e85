"""rules list: units, waivable rules; rules explain: case-insensitive, names its clause."""

from __future__ import annotations

from casekit import run_blockqc


def test_rules_list_units_and_waivable() -> None:
    p = run_blockqc("rules", "list")
    assert p.returncode == 0
    lines = p.stdout.splitlines()
    assert lines[0].split()[:4] == ["id", "clause", "sev.", "waiv."]
    tp4 = next(line for line in lines if line.startswith("TP-4"))
    assert "points" in tp4 and tp4.split()[3] == "yes"
    tp1 = next(line for line in lines if line.startswith("TP-1"))
    assert " px " in tp1 and tp1.split()[3] == "no"


def test_rules_explain_case_insensitive_with_overrides(tmp_path) -> None:
    pack = tmp_path / "p.yaml"
    pack.write_text("pack: p\nextends: global-project\nconstants:\n  norm: {plane_m: 5}\n")
    p = run_blockqc("rules", "explain", "cp-2", "--rules", pack)
    assert p.returncode == 0, p.stderr
    assert "CP-2" in p.stdout and "implements §CP-5" in p.stdout
    assert "threshold: ≤ 5" in p.stdout  # the project's norm, not the stock 10
    assert "class:" in p.stdout and "accuracy against norm.plane_m" in p.stdout
