"""The sample batch: per-block scores and grades, the batch decision, in both languages.

F3-B01 (sampled: it carries checkpoints) and F3-B02 fail on A-class errors. Their scores by hand,
stock weights (data .6, layout .2, attachment .2; in data: basis .2, plane .3, height .3, edge .2):
- F3-B01: plane (CP-2 beyond the norm), height (CP-4 gross rate) and edge (RO-3) hold A-class
  errors and score 0: data .2·100 = 20; block .6·20 + .2·100 + .2·100 = 52.
- F3-B02 (no checkpoints: height not inspected): edge 0 (RO-3); data re-weighted
  (.2·100 + .3·100 + .2·0)/.7 = 71.4286; block .6·71.4286 + 20 + 20 = 82.8571, yet it fails.
"""

from __future__ import annotations

import json
import shutil

import pytest

from blockqc.report import write_summary_report
from casekit import SAMPLES, run_blockqc


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    out = tmp_path_factory.mktemp("accept")
    proc = run_blockqc(
        "inspect", SAMPLES / "batch", "--verdicts", SAMPLES / "verdicts.yaml", "--out", out,
        "--no-pdf",
    )  # fmt: skip
    assert proc.returncode == 1, proc.stderr
    return out


def test_scores_grades_and_decision(out) -> None:
    s = json.loads((out / "summary.json").read_text())
    blocks = {b["block_id"]: b for b in s["blocks"]}
    assert blocks["F3-B01"]["score"] == pytest.approx(52.0)
    assert blocks["F3-B02"]["score"] == pytest.approx(0.6 * 50 / 0.7 + 40)
    assert blocks["F3-B01"]["grade"] == blocks["F3-B02"]["grade"] == "fail"
    assert all(b["grade"] == "excellent" for k, b in blocks.items() if not k.startswith("F3"))
    a = s["acceptance"]
    assert a["sample_source"] == "checkpoints"
    assert a["sample"] == ["F1-B01", "F2-B01", "F3-B01", "F4-B01"]
    assert a["decision"] == "fail" and a["batch_grade"] == "fail"
    (failing,) = a["failing"]
    assert failing["block_id"] == "F3-B01"
    named = {(e["rule"], tuple(e["group"].values())) for e in failing["a_errors"]}
    assert {("CP-2", ("plane", "high_precision")), ("RO-3", ("plane",))} <= named
    assert [(b["block_id"], [e["rule"] for e in b["a_errors"]]) for b in a["returned"]] == [
        ("F3-B02", ["RO-3"])
    ]
    r = json.loads((out / "F3-B01" / "results.json").read_text())
    assert r["evaluation"]["counts"]["A"] == len(named)


@pytest.mark.parametrize(
    ("lang", "words"),
    [
        ("en", ["Batch decision", "Rejected (fail)", "A-class error: CP-2", "Excellent"]),
        ("zh", ["批成果质量判定", "批成果不合格", "A 类错漏：CP-2", "优"]),
    ],
)
def test_summary_and_filed_report_in_both_languages(out, tmp_path, lang, words) -> None:
    doc = json.loads((out / "summary.json").read_text())
    write_summary_report(tmp_path, doc, lang=lang, pdf=False)
    html = (tmp_path / "summary.html").read_text()
    for w in words:
        assert w in html, w
    filed = (tmp_path / "acceptance.html").read_text()
    assert 'data-decision="fail"' in filed and "F3-B02" in filed
    assert str(SAMPLES) not in filed and str(out) not in filed  # no paths of this machine


def test_summary_and_filed_pdfs_side_by_side_are_the_same(out, tmp_path) -> None:
    """With jobs > 1 the acceptance PDF is laid out in another process: the same files."""
    doc = json.loads((out / "summary.json").read_text())
    written = write_summary_report(tmp_path, doc, pdf=True, jobs=1)
    assert {p.name for p in written} >= {"summary.pdf", "acceptance.pdf"}
    first = {p: p.read_bytes() for p in written}
    assert write_summary_report(tmp_path, doc, pdf=True, jobs=2) == written
    for p in written:
        assert p.read_bytes() == first[p], p.name


PACK_OWN_NAMES = """\
pack: own-names
version: "1.0"
extends: global-project
acceptance:
  element_fail_below: 97
  grades:
    - {id: A1, min: 90, title: Top, title_zh: 顶级}
    - {id: B1, min: 75, title: Mid, title_zh: 中级}
    - {id: C1, min: 60, title: Low, title_zh: 低级}
  fail_grade: {id: rejected, min: 0, title: Rejected, title_zh: 拒收}
  better_than: B1
  batch_grades:
    - {grade: A1, better_pct: 90, top_pct: 50}
  batch_default: C1
"""


def test_the_packs_grade_names_and_element_bound_are_what_the_pages_show(tmp_path) -> None:
    """F1-B01 scores 97.44 with its data element at 95.7 (< 97: it fails); the pages said
    'below 60' and showed the grade ids (rejected, A1) instead of the pack's titles."""
    pack = tmp_path / "own-names.yaml"
    pack.write_text(PACK_OWN_NAMES, encoding="utf-8")
    out = tmp_path / "out"
    args = ("--rules", pack, "--verdicts", SAMPLES / "verdicts.yaml", "--no-pdf")
    assert run_blockqc("inspect", SAMPLES / "batch", *args, "--out", out).returncode == 1
    block = (out / "F1-B01" / "report.html").read_text(encoding="utf-8")
    assert "Rejected" in block and "(below 97)" in block and "(below 60)" not in block
    for page in ("summary.html", "acceptance.html"):
        html = (out / page).read_text(encoding="utf-8")
        assert "(below 97)" in html and "Rejected" in html and "Top" in html, page
        assert "rejected 5" not in html and ">rejected<" not in html, page
    zh = tmp_path / "zh"
    assert run_blockqc("report", out, "--out", zh, "--lang", "zh", "--no-pdf").returncode == 0
    html = (zh / "summary.html").read_text(encoding="utf-8")
    assert "拒收" in html and "顶级" in html and "（低于 97 分）" in html


def test_a_fail_grade_of_the_packs_own_id_is_shown_as_failing(tmp_path) -> None:
    """F3-B01 fails (52.0, A-class errors) under a pack whose fail grade is `rejected`: its grade
    was shown in the colours of a passing grade (only the id `fail` was), on its report, on
    summary.html and in the filed report's statistics; F1-B01 (excellent) passes."""
    pack = tmp_path / "rejected.yaml"
    pack.write_text(
        "pack: rejected\nversion: '1'\nextends: global-project\nacceptance:\n"
        "  fail_grade: {id: rejected, min: 0, title: Rejected, title_zh: 拒收}\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    blocks = [SAMPLES / "batch" / b for b in ("F1-B01", "F3-B01")]
    args = ("--rules", pack, "--verdicts", SAMPLES / "verdicts.yaml", "--no-pdf", "--out", out)
    assert run_blockqc("inspect", *blocks, *args).returncode == 1
    failing = '<span class="status fail">Rejected</span>'
    report = (out / "F3-B01" / "report.html").read_text(encoding="utf-8")
    assert f'data-grade="rejected">52.0 — {failing}' in report
    assert f"52.0 — {failing}" in report.split('<section id="evaluation">', 1)[1]
    summary = (out / "summary.html").read_text(encoding="utf-8")
    assert f'<td data-grade="rejected">{failing}</td>' in summary
    assert '<td data-grade="excellent"><span class="status pass">Excellent</span>' in summary
    filed = (out / "acceptance.html").read_text(encoding="utf-8")
    row = filed.split('id="grades-table"', 1)[1].split('<td class="id">F3-B01</td>', 1)[1]
    assert row.split("</tr>", 1)[0].endswith(f"<td>{failing}</td>")


def test_sampled_blocks_with_rules_failed_are_main_quality_problems(tmp_path) -> None:
    """TP-4 asking 280 points per PAN scene fails on F1-B01 (271) and F2-B01, both sampled
    (they carry checkpoints): a C-class error each, deducted (4 points from the points
    distribution item), the sample passes. The filed report said "No quality problem was found";
    it now lists both, with the rule failed, their grades shown as passing."""
    pack = tmp_path / "tight.yaml"
    pack.write_text(
        "pack: tight\nversion: '1'\nextends: global-project\n"
        "overrides:\n  TP-4: {threshold: {min: 280}}\n",
        encoding="utf-8",
    )
    verdicts = tmp_path / "verdicts.yaml"
    verdicts.write_text("verdicts:\n  DOC-3: {status: pass, note: follows the templates}\n")
    out = tmp_path / "out"
    blocks = [SAMPLES / "batch" / b for b in ("F1-B01", "F2-B01")]
    args = ("--rules", pack, "--verdicts", verdicts, "--no-pdf", "--out", out)
    assert run_blockqc("inspect", *blocks, *args).returncode == 1
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))["acceptance"]
    assert s["decision"] == "pass" and s["sample"] == ["F1-B01", "F2-B01"] and not s["returned"]
    filed = (out / "acceptance.html").read_text(encoding="utf-8")
    problems = filed.split('<section id="problems">', 1)[1].split("</section>", 1)[0]
    assert "No quality problem was found." not in problems
    for block in ("F1-B01", "F2-B01"):
        row = problems.split(f'<td class="id">{block}</td>', 1)[1].split("</tr>", 1)[0]
        assert '<span class="status pass">Excellent</span>' in row and "rules failed: TP-4" in row


def test_without_a_plan_a_sample_below_the_table_is_said(tmp_path, out) -> None:
    """F1-B01, F2-B01 (with checkpoints) and F1-B02 (without): a batch of 3, of which the table
    asks 3 (every unit, §QE-1); the sample is the 2 blocks with checkpoints. The batch was
    accepted on them with no word of the table; the pages now say it. The sample batch's 4 of 8
    (the table asks 3) are not said short."""
    verdicts = tmp_path / "verdicts.yaml"
    verdicts.write_text("verdicts:\n  DOC-3: {status: pass, note: follows the templates}\n")
    three = tmp_path / "out"
    blocks = [SAMPLES / "batch" / b for b in ("F1-B01", "F2-B01", "F1-B02")]
    args = ("--verdicts", verdicts, "--no-pdf", "--out", three)
    assert run_blockqc("inspect", *blocks, *args).returncode == 0
    s = json.loads((three / "summary.json").read_text(encoding="utf-8"))["acceptance"]
    assert s["decision"] == "pass" and s["sample"] == ["F1-B01", "F2-B01"]
    said = (
        "The pack's table (§QE-1) asks a sample of 3 of a batch of 3 deliveries; 2 carry "
        "checkpoints: the batch is judged on the smaller sample."
    )
    for page in ("acceptance.html", "summary.html"):
        assert said.replace("'", "&#39;") in (three / page).read_text(encoding="utf-8"), page
        assert 'id="short-sample"' not in (out / page).read_text(encoding="utf-8"), page
    zh = tmp_path / "zh"
    assert run_blockqc("report", three, "--out", zh, "--lang", "zh", "--no-pdf").returncode == 0
    text = (zh / "acceptance.html").read_text(encoding="utf-8")
    assert "规则包的抽样表（§QE-1）要求从 3 个成果中抽取 3 个；带检查点的仅 2 个" in text


def _inspect_f1(tmp_path, pack_text: str | None, status: int) -> dict:
    """F1-B01 inspected with a pack of `pack_text` (None: the stock pack), expecting `status`;
    its results.json."""
    out = tmp_path / ("stock" if pack_text is None else "own")
    args = ("--out", out, "--pdf", "none")
    if pack_text is not None:
        pack = tmp_path / "pack.yaml"
        pack.write_text(pack_text, encoding="utf-8")
        args += ("--rules", pack)
    p = run_blockqc("inspect", SAMPLES / "batch" / "F1-B01", *args)
    assert p.returncode == status, p.stderr
    return json.loads((out / "F1-B01" / "results.json").read_text())


def test_a_rule_placed_by_its_quality_element_alone_counts_in_the_grade(tmp_path) -> None:
    """A rule deciding no content, placed with `quality_element: layout`, A-class, failing on
    F1-B01 (its smallest PAN scene holds 271 points < 280): the block fails its evaluation
    (its errors count in every item of the element); it was graded excellent, 97.44."""
    pack = (
        "pack: by-element\nversion: '1'\nextends: global-project\nrules:\n"
        "  - {id: PR-1, title: t, clause: §TP-4, metric: tie_point_distribution,\n"
        "     params: {bands: [pan]}, scope: scene, statistic: n_points,\n"
        "     threshold: {min: 280}, unit: points, error_class: A, quality_element: layout}\n"
    )
    ev = _inspect_f1(tmp_path, pack, 1)["evaluation"]
    assert ev["fails"] and ev["grade"] == "fail" and ev["counts"]["A"] == 1
    layout = next(e for e in ev["elements"] if e["id"] == "layout")
    assert layout["score"] == 0


@pytest.mark.parametrize(("cls", "fails"), [("A", True), ("C", False)])
def test_a_rule_deciding_no_content_counts_its_errors_for_the_block(tmp_path, cls, fails) -> None:
    """The same rule (F1-B01's smallest PAN scene holds 271 points < 280) placed nowhere: no
    `content`, no `quality_element` (an "other rule" of the pack). Its error counted in no item
    and was dropped: A-class, the block was graded excellent, 97.44, with no error. It now counts
    for the block: an A-class one fails it; any class is in its counts and `other_errors`, and
    no item's score changes (97.44, as without the rule)."""
    pack = (
        "pack: unplaced\nversion: '1'\nextends: global-project\nrules:\n"
        "  - {id: PR-1, title: t, clause: §TP-4, metric: tie_point_distribution,\n"
        "     params: {bands: [pan]}, scope: scene, statistic: n_points,\n"
        f"     threshold: {{min: 280}}, unit: points, error_class: {cls}}}\n"
    )
    ev = _inspect_f1(tmp_path, pack, 1)["evaluation"]
    assert ev["fails"] is fails and ev["grade"] == ("fail" if fails else "excellent")
    assert ev["counts"] == {"A": 0, "B": 0, "C": 0, "D": 0, cls: 1}
    (err,) = ev["other_errors"]
    assert (err["rule"], err["error_class"], err["value"], err["threshold"]) == (
        "PR-1",
        cls,
        271,
        280,
    )
    assert ev["score"] == pytest.approx(97.44, abs=0.005)
    assert ("A-class error: PR-1 271 (fails its threshold)" in ev["reasons"]) is fails


def test_an_accuracy_rule_given_a_range_keeps_its_upper_bound_as_norm(tmp_path) -> None:
    """RO-4 bounded {min: 0, max: √2·m} instead of {max: √2·m}: the same norm, so the same
    accuracy scores and block score (97.44 on F1-B01); the range dropped them (98.13)."""

    def score(*pack_text: str) -> tuple[float, list]:
        text = "\n".join(pack_text) + "\n" if pack_text else None
        ev = _inspect_f1(tmp_path, text, 0)["evaluation"]
        acc = [a for e in ev["elements"] for i in e["items"] for a in i["accuracy"]]
        return ev["score"], sorted((a["rule"], a["norm"], a["score"]) for a in acc)

    ranged = score(
        "pack: range", "version: '1'", "extends: global-project", "overrides:", "  RO-4:",
        "    thresholds:", "      plane: {min: 0, max: sqrt(2) * norm.plane_m}",
        "      height: {min: 0, max: sqrt(2) * norm.height_m}",
    )  # fmt: skip
    stock = score()
    assert ranged[0] == pytest.approx(stock[0]) and ranged[1] == stock[1]
    assert any(rule == "RO-4" for rule, _, _ in stock[1])


def test_an_accuracy_norm_may_name_the_deliverys_gsd(tmp_path) -> None:
    """RO-1 scored against norm gsd.ms (2.6 m on F1-B01), as thresholds may name it: the
    score is 60 + 40·(2.6 − m)/(0.7·2.6) by hand; every delivery was reported unreadable."""
    pack = (
        "pack: gsd-norm\nversion: '1'\nextends: global-project\noverrides:\n"
        "  RO-1: {score: {kind: accuracy, norm: gsd.ms}}\n"
    )
    doc = _inspect_f1(tmp_path, pack, 0)
    (ro1,) = [r for r in doc["results"] if r["rule"] == "RO-1"]
    acc = [a for e in doc["evaluation"]["elements"] for i in e["items"] for a in i["accuracy"]]
    (rec,) = [a for a in acc if a["rule"] == "RO-1"]
    m = ro1["value"]
    assert rec["norm"] == pytest.approx(2.6)
    assert rec["score"] == pytest.approx(60 + 40 * (2.6 - m) / (0.7 * 2.6))


def test_an_accuracy_norm_naming_a_gsd_the_delivery_lacks_is_said(tmp_path) -> None:
    """RO-1 judged against 2.6 m and scored against norm gsd.ms, on F1-B01 without its MS GSD:
    judged (its threshold names no GSD), it cannot be scored; it was scored by deduction alone
    (100 on a pass) and the evaluation said complete. Now unscored, it makes the evaluation
    incomplete, naming the rule and the band."""
    block = tmp_path / "F1-B01"
    shutil.copytree(SAMPLES / "batch" / "F1-B01", block)
    text = (block / "block.yaml").read_text(encoding="utf-8")
    (block / "block.yaml").write_text(text.replace("  ms: 2.6\n", ""), encoding="utf-8")
    pack = tmp_path / "pack.yaml"
    pack.write_text(
        "pack: gsd-norm\nversion: '1'\nextends: global-project\noverrides:\n"
        "  RO-1: {threshold: {max: 2.6}, score: {kind: accuracy, norm: gsd.ms}}\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    verdicts = tmp_path / "verdicts.yaml"
    verdicts.write_text("inspector: Li Wei\nverdicts:\n  DOC-3: {status: pass}\n", "utf-8")
    args = ("--rules", pack, "--verdicts", verdicts, "--out", out, "--pdf", "none")
    p = run_blockqc("inspect", block, *args)
    assert p.returncode == 0, p.stderr
    doc = json.loads((out / "F1-B01" / "results.json").read_text())
    ev = doc["evaluation"]
    said = (
        "RO-1 not scored: block.yaml gives no gsd_m.ms, which its score.norm (gsd.ms) needs: "
        "add the MS GSD in metres to gsd_m"
    )
    assert (ev["complete"], ev["reasons"]) == (False, [said])
    zh = tmp_path / "zh"
    assert run_blockqc("report", out, "--out", zh, "--lang", "zh", "--no-pdf").returncode == 0
    page = (zh / "F1-B01" / "report.html").read_text(encoding="utf-8")
    assert "not scored" not in page
    assert (
        "RO-1 未计分：block.yaml 未给出 gsd_m.ms，而其 score.norm（gsd.ms）需要它："
        "请在 gsd_m 中给出以米为单位的 MS 地面采样距离"
    ) in page


def test_why_an_evaluation_is_incomplete_is_said_in_the_pages_language() -> None:
    """The reasons results.json records in English (a rule not judged, a rule not scored and
    why) read in Chinese on a zh page, the rule ids and the norm as written."""
    from types import SimpleNamespace

    from blockqc.acceptance.evaluate import incomplete_reasons
    from blockqc.report.acceptance import reason_text
    from blockqc.report.format import Formatter

    error = SimpleNamespace(rule="RO-2", status="error", detail={})
    results = SimpleNamespace(results=[error], pending_manual=[])
    (why,) = incomplete_reasons(results)
    assert why == "rule RO-2 could not be judged"
    zh, en = Formatter("zh"), Formatter("en")
    assert (reason_text(why, zh), reason_text(why, en)) == ("规则 RO-2 无法判定", why)
    other = "PA-1 not scored: score.norm (2 * k): unknown name 'k'"
    assert reason_text(other, zh) == "PA-1 未计分：score.norm（2 * k）无法计算：unknown name 'k'"
