"""§QE-2..5 block scores and grades against hand computation, with the stock pack's weights.

Stock weights: elements data .6, layout .2, attachment .2; items in data: mathematical basis .2,
plane .3, height .3, edge .2; layout: points distribution 1; attachment: report .5, documents .5.
Deduction 100 − (12·nB + 4·nC + nD); accuracy 100 for m ≤ 0.3·m0, 60 + 40·(m0 − m)/(0.7·m0)
up to m0. Rule ids below are the stock ones where they matter, free labels elsewhere.
"""

from __future__ import annotations

import pytest

from blockqc.acceptance.model import Grade
from blockqc.acceptance.scoring import Finding, accuracy_score, deduction_score, evaluate_block
from blockqc.report.acceptance import evaluation_context, reason_text
from blockqc.report.format import Formatter
from blockqc.rules import load_pack
from casekit import extension_pack

PACK = load_pack("global-project")
ACC = PACK.acceptance
TREE = {c.id: (e.id, i.id) for e in PACK.elements for i in e.items for c in i.contents}


def ok(rule: str, content: str, **kw) -> Finding:
    return Finding(rule=rule, status="pass", places=(TREE[content],), error_class="C", **kw)


def bad(rule: str, content: str, cls: str, **kw) -> Finding:
    return Finding(rule=rule, status="fail", places=(TREE[content],), error_class=cls, **kw)


def acc(rule: str, content: str, m: float, m0: float, status: str = "pass") -> Finding:
    return Finding(
        rule=rule, status=status, places=(TREE[content],), error_class="C", value=m, norm=m0
    )


def base() -> list[Finding]:
    """Every item inspected and clean (scores 100)."""
    return [
        ok("MB-1", "coordinate_system"),
        ok("RO-1", "pan_ms"),
        ok("RO-3", "within_block"),
        ok("TP-4", "tp_number"),
        ok("TP-1", "ro_report"),
        ok("DOC-1", "documents"),
    ]


def run(findings: list[Finding]):
    return evaluate_block(PACK.elements, findings, ACC)


def scores(ev) -> dict[str, float]:
    out = {e.id: e.score for e in ev.elements}
    out.update({i.id: i.score for e in ev.elements for i in e.items})
    return out


def test_accuracy_score_formula() -> None:
    assert accuracy_score(3.0, 10.0) == 100.0  # 0.3·m0 itself scores 100
    assert accuracy_score(6.5, 10.0) == pytest.approx(80.0)  # 60 + 40·3.5/7
    assert accuracy_score(10.0, 10.0) == pytest.approx(60.0)  # the norm itself scores 60
    assert accuracy_score(10.0001, 10.0) is None  # beyond the norm: A-class
    assert deduction_score({"B": 1, "C": 2, "D": 3}, ACC) == 100 - (12 + 8 + 3)


def test_grade_excellent() -> None:
    # plane 2.5 ≤ 3 → 100; height 1.5 ≤ 1.8 → 100; DOC-3 a D error: documents 99
    # attachment .5·100 + .5·99 = 99.5; block .6·100 + .2·100 + .2·99.5 = 99.9
    ev = run(
        base()
        + [
            acc("CP-2", "cp_plane", 2.5, 10),
            acc("CP-3", "cp_height", 1.5, 6),
            bad("DOC-3", "documents", "D"),
        ]
    )
    assert scores(ev)["documents"] == 99
    assert ev.score == pytest.approx(99.9)
    assert (ev.grade, ev.fails, ev.counts) == ("excellent", False, {"A": 0, "B": 0, "C": 0, "D": 1})


def test_grade_good() -> None:
    # plane 8.6: 60 + 40·1.4/7 = 68; height 5.3: 60 + 40·0.7/4.2 = 66.667
    # data .2·100 + .3·68 + .3·66.667 + .2·100 = 80.4
    # layout: TP-4 C, TP-5 D → 95; attachment: TP-1 B in report → 88, documents 100 → 94
    # block .6·80.4 + .2·95 + .2·94 = 48.24 + 19 + 18.8 = 86.04
    f = [x for x in base() if x.rule not in ("TP-4", "TP-1")]
    f += [
        acc("CP-2", "cp_plane", 8.6, 10),
        acc("CP-3", "cp_height", 5.3, 6),
        bad("TP-4", "tp_number", "C"),
        bad("TP-5", "tp_distribution", "D"),
        bad("TP-1", "ro_report", "B"),
    ]
    ev = run(f)
    s = scores(ev)
    assert s["plane_accuracy"] == pytest.approx(68)
    assert s["height_accuracy"] == pytest.approx(200 / 3)
    assert s["data"] == pytest.approx(80.4)
    assert (s["layout"], s["attachment"]) == (95, 94)
    assert ev.score == pytest.approx(86.04)
    assert ev.grade == "good" and not ev.fails


def test_grade_pass() -> None:
    # plane 9.3 and height 5.58: 60 + 40·0.7/7 = 64 and 60 + 40·0.42/4.2 = 64
    # data .2·100 + .3·64 + .3·64 + .2·100 = 78.4
    # layout: three B errors → 100 − 36 = 64
    # report: 2 B, 2 C, 1 D → 100 − (24 + 8 + 1) = 67; documents: 3 B, 3 D → 61; attachment 64
    # block .6·78.4 + .2·64 + .2·64 = 72.64
    f = base() + [acc("CP-2", "cp_plane", 9.3, 10), acc("CP-3", "cp_height", 5.58, 6)]
    f += [bad(f"L-{i}", "tp_number", "B") for i in range(3)]
    f += [
        bad(f"R-{c}{i}", "ro_report", c)
        for c, n in (("B", 2), ("C", 2), ("D", 1))
        for i in range(n)
    ]
    f += [bad(f"D-{c}{i}", "documents", c) for c in "BD" for i in range(3)]
    ev = run(f)
    s = scores(ev)
    assert (s["layout"], s["report"], s["documents"], s["attachment"]) == (64, 67, 61, 64)
    assert s["data"] == pytest.approx(78.4)
    assert ev.score == pytest.approx(72.64)
    assert ev.grade == "pass" and not ev.fails
    assert ev.counts == {"A": 0, "B": 3 + 2 + 3, "C": 2, "D": 1 + 3}


def test_fail_element_below_60() -> None:
    # layout: four B errors → 100 − 48 = 52 < 60: the block fails though it scores
    # .6·100 + .2·52 + .2·100 = 90.4
    ev = run(base() + [bad(f"L-{i}", "tp_number", "B") for i in range(4)])
    assert ev.score == pytest.approx(90.4)
    assert ev.fails and ev.grade == "fail"
    assert ev.reasons == ["element layout scores 52.0 < 60"]


def test_fail_a_class_error() -> None:
    # plane 15.7 > 10: an A-class error, the item scores 0
    # data .2·100 + .3·0 + .3·100 + .2·100 = 70; block .6·70 + .2·100 + .2·100 = 82, but fails
    f = base() + [
        acc("CP-2", "cp_plane", 15.7, 10, status="fail"),
        acc("CP-3", "cp_height", 1.0, 6),
    ]
    ev = run(f)
    assert scores(ev)["plane_accuracy"] == 0
    assert ev.score == pytest.approx(82)
    assert ev.fails and ev.grade == "fail"
    assert ev.counts["A"] == 1
    assert ev.reasons[0].startswith("A-class error: CP-2 15.70")


def test_several_b_c_d_reweighted() -> None:
    # height not inspected (not applicable): data re-weighted over .2 + .3 + .2 = .7
    # plane: accuracy 6.5 → 80, less RO-1 (B) 12 → 68; edge: one C, one D → 95
    # data (.2·100 + .3·68 + .2·95)/.7 = 59.4/.7 = 84.857143
    # layout: TP-4 C, TP-5 D → 95; report: DOC-2 C → 96; documents: DOC-1 B, DOC-3 D → 87
    # attachment .5·96 + .5·87 = 91.5; block .6·84.857143 + .2·95 + .2·91.5 = 88.214286
    f = [
        ok("MB-1", "coordinate_system"),
        acc("CP-2", "cp_plane", 6.5, 10),
        Finding("CP-3", "not_applicable", (TREE["cp_height"],), "C"),
        bad("RO-1", "pan_ms", "B"),
        bad("RO-2", "between_blocks", "C"),
        bad("RO-9", "within_block", "D"),
        bad("TP-4", "tp_number", "C"),
        bad("TP-5", "tp_distribution", "D"),
        bad("DOC-2", "ro_report", "C"),
        bad("DOC-1", "documents", "B"),
        bad("DOC-3", "documents", "D"),
    ]
    ev = run(f)
    s = scores(ev)
    assert s["height_accuracy"] is None
    assert (s["plane_accuracy"], s["edge_accuracy"], s["report"], s["documents"]) == (
        68,
        95,
        96,
        87,
    )
    assert s["data"] == pytest.approx(59.4 / 0.7)
    assert ev.score == pytest.approx(0.6 * 59.4 / 0.7 + 19 + 18.3)
    assert ev.grade == "good" and not ev.fails
    assert ev.counts == {"A": 0, "B": 2, "C": 3, "D": 3}


def test_warnings_waivers_and_manual_are_not_errors() -> None:
    f = base() + [
        Finding("CP-5", "warn", (TREE["cp_plane"],), "D"),
        Finding("TP-4", "waived", (TREE["tp_number"],), "C"),
        Finding("DOC-3", "manual", (TREE["documents"],), "D"),
    ]
    ev = run(f)
    assert ev.score == 100 and ev.counts == {"A": 0, "B": 0, "C": 0, "D": 0}


def test_a_waived_accuracy_result_beyond_its_norm_is_not_an_a_class_error() -> None:
    """The inspector waived RO-3 at 7.90 m against 7.07: no error, and nothing to score beyond
    the norm (within it, a waived result scores as any: 5.0 of 10 → 60 + 40·5/7)."""
    beyond = run(base() + [acc("RO-3", "within_block", 7.90, 7.07, status="waived")])
    assert not beyond.fails and beyond.counts["A"] == 0 and beyond.score == 100
    within = run(base() + [acc("RO-3", "within_block", 5.0, 10.0, status="waived")])
    assert scores(within)["edge_accuracy"] == pytest.approx(60 + 40 * 5 / 7)
    failed = run(base() + [acc("RO-3", "within_block", 7.90, 7.07, status="fail")])
    assert failed.fails and failed.counts["A"] == 1


def test_a_weighted_score_on_a_grade_bound_reaches_it() -> None:
    # mathematical basis alone in data: a B and a D error, 100 − 12 − 1 = 87; points distribution
    # two C and two D errors, 100 − 8 − 2 = 90; documents alone in attachment: a D error, 99.
    # Block .6·87 + .2·90 + .2·99 = 52.2 + 18 + 19.8 = 90: excellent (≥ 90)
    ev = run(
        [
            bad("MB-3", "projection", "B"),
            bad("MB-x", "coordinate_system", "D"),
            bad("TP-4", "tp_number", "C"),
            bad("TP-x", "tp_number", "C"),
            bad("TP-5", "tp_distribution", "D"),
            bad("TP-y", "tp_distribution", "D"),
            bad("DOC-3", "documents", "D"),
        ]
    )
    got = scores(ev)
    assert (got["data"], got["layout"], got["attachment"]) == (87, 90, 99)
    assert ev.score == 90
    assert (ev.grade, ev.fails) == ("excellent", False)


def test_an_element_on_the_fail_bound_does_not_fail() -> None:
    # plane alone in data: m = 9.3 m of m0 = 10 scores 60 + 40·0.7/7 = 64, less a C error
    # (4): 60, not below 60, so the block does not fail (§QE-2); .6·60 + .2·100 + .2·100 = 76
    ev = run(
        [
            acc("CP-2", "cp_plane", 9.3, 10),
            bad("CP-1", "cp_plane", "C"),
            ok("TP-4", "tp_number"),
            ok("DOC-1", "documents"),
        ]
    )
    assert accuracy_score(9.3, 10) == 64
    assert scores(ev)["data"] == 60
    assert (ev.fails, ev.reasons, ev.score, ev.grade) == (False, [], 76, "good")


def test_items_inspected_that_all_weigh_0_give_their_element_no_score(tmp_path) -> None:
    """documents weighted 0 (not counted) and report not inspected: the element has nothing
    counted and is left out. It took the plain mean of its items, documents' 100 − 4·12 = 52,
    and failed the block (attachment 52 < 60) on an item the pack does not count.
    Block by hand: (.6·100 + .2·100)/.8 = 100; the four B errors are still errors."""
    pack = load_pack(
        extension_pack(tmp_path, "acceptance:\n  weights:\n    items: {documents: 0}\n")
    )
    f = [x for x in base() if x.rule != "TP-1"] + [
        bad(f"D-{i}", "documents", "B") for i in range(4)
    ]
    ev = evaluate_block(pack.elements, f, pack.acceptance)
    attachment = next(e for e in ev.elements if e.id == "attachment")
    assert scores(ev)["documents"] == 52 and scores(ev)["report"] is None
    assert (attachment.score, attachment.inspected) == (None, True)
    assert ev.score == 100 and not ev.fails and ev.grade == "excellent"
    assert ev.counts["B"] == 4 and ev.reasons == []
    rows = {r["name"]: r["score"] for r in evaluation_context(ev, Formatter("en"))["rows"]}
    assert rows["Attachment quality"] == "only items of weight 0 inspected"


def test_a_score_a_hair_below_a_grade_bound_is_kept_below_it() -> None:
    """plane alone inspected: m = 4.75000007 of m0 = 10 scores 60 + 40·5.24999993/7 =
    89.9999996, good (< 90). Kept to 9 decimals, the block's score stays below 90: rounded to 6
    it read 90.0, the bound of a grade it does not reach, on the page and in the sample's mean."""
    ev = run([acc("CP-2", "cp_plane", 4.75000007, 10)])
    assert ev.score == pytest.approx(89.9999996, abs=1e-9) and ev.score < 90
    assert ev.grade == "good"
    assert evaluation_context(ev, Formatter("en"))["score"].startswith("89.9")


def test_a_score_below_every_grade_fails_the_block(tmp_path) -> None:
    """A project's lowest grade, pass, from 70: plane alone inspected, m = 9.3 m of m0 = 10
    scores 64 (≥ 60: no element fails), below every grade. The block fails, graded so and
    said, rather than being graded 'fail' while not failing (a sample of it then passed)."""
    grades = (
        "acceptance:\n  grades:\n"
        "    - {id: excellent, min: 90, title: Excellent}\n"
        "    - {id: good, min: 80, title: Good}\n"
        "    - {id: pass, min: 70, title: Pass}\n"
    )
    pack = load_pack(extension_pack(tmp_path, grades))
    ev = evaluate_block(pack.elements, [acc("CP-2", "cp_plane", 9.3, 10)], pack.acceptance)
    assert ev.score == 64
    assert (ev.fails, ev.grade) == (True, "fail")
    assert ev.reasons == ["score below the lowest grade: 64.0 < 70 (pass)"]
    assert reason_text(ev.reasons[0], Formatter("zh")).startswith("得分低于最低质量等级")


@pytest.mark.parametrize(
    ("grades", "shown"),
    [((), "合格"), ([Grade(id="pass", min=70, title="Pass", title_zh="及格")], "及格")],
)
def test_the_grade_a_score_does_not_reach_is_named_in_chinese(grades, shown) -> None:
    """The zh page read '得分低于最低质量等级: 52.0 < 60 (pass)', the grade's English id left in;
    it names the grade as the page does (the pack's title, else the catalogue's)."""
    text = reason_text("score below the lowest grade: 52.0 < 60 (pass)", Formatter("zh", grades))
    assert text == f"得分低于最低质量等级：52.0 < 60（{shown}）"


def test_the_reasons_of_a_block_are_punctuated_in_chinese() -> None:
    """The zh batch pages read 'RO-3 平面 36.42 （超出限值）' and 'CP-1: 已抽为详查样本…': a
    space before the full-width bracket, an ASCII colon after the rule."""
    from blockqc.acceptance.model import BlockGrade, ErrorRecord
    from blockqc.acceptance.plan import NO_CHECKPOINTS
    from blockqc.report.acceptance import _reasons

    error = ErrorRecord(
        rule="RO-3",
        error_class="A",
        group={"component": "plane"},
        value=36.42,
        threshold=28.28,
        reason="fails its threshold",
    )
    reasons = [f"CP-1: {NO_CHECKPOINTS}"]
    line = BlockGrade(block_id="B1", sampled=True, fails=True, a_errors=[error], reasons=reasons)
    assert _reasons(line, Formatter("zh")) == [
        "A 类错漏：RO-3 平面 36.42（超出限值）",
        "CP-1：已抽为详查样本，但成果中没有检查点：详查不完整",
    ]
    assert _reasons(line, Formatter("en")) == [
        "A-class error: RO-3 Plane 36.42 (fails its threshold)",
        f"CP-1: {NO_CHECKPOINTS}",
    ]


def test_the_a_class_errors_of_the_batch_pages_show_what_they_miss() -> None:
    """summary.html and acceptance.html listed 'CP-4 Plane · High-precision data 37.50 (fails
    its threshold)': neither the unit (a share or metres?) nor the threshold failed. They now
    read as the block report's table: the value with its unit, and the threshold it fails or,
    beyond the norm (§QE-3), the norm m0 it exceeds."""
    from blockqc.acceptance.model import BlockGrade, ErrorRecord
    from blockqc.report.acceptance import _reasons

    rate = ErrorRecord(
        rule="CP-4",
        error_class="A",
        group={"component": "plane", "method": "high_precision"},
        value=37.5,
        threshold=5.0,
        comparison="<",
        unit="%",
        reason="fails its threshold",
    )
    # a pack whose threshold (≤ 20 m) is wider than the norm: 15.7 m passes it, beyond m0 = 10
    beyond = ErrorRecord(
        rule="CP-2",
        error_class="A",
        group={"component": "plane"},
        value=15.7,
        threshold=20.0,
        comparison="<=",
        unit="m",
        norm=10.0,
        reason="beyond the norm",
    )
    line = BlockGrade(block_id="B1", sampled=True, fails=True, a_errors=[rate, beyond])
    assert _reasons(line, Formatter("en")) == [
        "A-class error: CP-4 Plane · High-precision data 37.50 % (fails its threshold: < 5 %)",
        "A-class error: CP-2 Plane 15.70 m (beyond the norm: 10 m)",
    ]
    assert _reasons(line, Formatter("zh")) == [
        "A 类错漏：CP-4 平面 · 高精度数据法 37.50 %（超出限值：< 5 %）",
        "A 类错漏：CP-2 平面 15.70 m（超过规定中误差：10 m）",
    ]


def test_the_a_class_errors_of_a_block_record_what_they_miss() -> None:
    """The error records of an evaluation keep the comparison and unit of their result, and an
    error beyond the norm its norm, for the pages to show."""
    from blockqc.acceptance.scoring import Finding, score_item

    acc = load_pack("global-project").acceptance
    item = score_item(
        [
            Finding("CP-2", "fail", (), "C", 15.7, 10.0, norm=10.0, comparison="<=", unit="m"),
            Finding("RO-3", "fail", (), "A", 38.98, 28.28, comparison="<", unit="m"),
        ],
        acc,
    )
    got = [(x.rule, x.error_class, x.reason, x.comparison, x.unit, x.norm) for x in item.errors]
    assert got == [
        ("CP-2", "A", "beyond the norm", "<=", "m", 10.0),
        ("RO-3", "A", "fails its threshold", "<", "m", None),
    ]
