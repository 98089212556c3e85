"""`blockqc report` re-derives a summary's batch decision (§QE-5) from its blocks' results files,
as `inspect` made it, and refuses a summary whose `acceptance` section says otherwise: exit 2,
the summary and the field named, what it says and what its blocks make; nothing written.

The sample batch fails (F3-B01, sampled, fails; F3-B02 is returned). F1-B01, F1-B02, F2-B01 and
F4-B01 inspected together pass: the three carrying checkpoints form the sample, all excellent."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from blockqc.cli import main
from casekit import SAMPLES, run_blockqc

VERDICTS = "verdicts:\n  DOC-3: {status: pass, note: follows the templates}\n"


def run(*args: object) -> int:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    return exc.value.code


@pytest.fixture(scope="module")
def failing(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("failing") / "out"
    args = ("--verdicts", SAMPLES / "verdicts.yaml", "--no-pdf")
    p = run_blockqc("inspect", SAMPLES / "batch", *args, "--out", out)
    assert p.returncode == 1, p.stderr
    return out


@pytest.fixture(scope="module")
def passing(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("passing")
    (base / "verdicts.yaml").write_text(VERDICTS, encoding="utf-8")
    blocks = [SAMPLES / "batch" / b for b in ("F1-B01", "F1-B02", "F2-B01", "F4-B01")]
    args = ("--verdicts", base / "verdicts.yaml", "--no-pdf", "--out", base / "out")
    p = run_blockqc("inspect", *blocks, *args)
    assert p.returncode == 0, p.stderr
    return base / "out"


def _edited(tmp_path: Path, out: Path, **fields: Any) -> Path:
    """A copy of a batch's outputs whose summary's acceptance section has `fields` changed."""
    copy = tmp_path / "in"
    shutil.copytree(out, copy)
    s = json.loads((copy / "summary.json").read_text(encoding="utf-8"))
    s["acceptance"].update(fields)
    (copy / "summary.json").write_text(json.dumps(s), encoding="utf-8")
    return copy


def _refused(tmp_path: Path, capsys, out: Path, **fields: Any) -> list[str]:
    copy = _edited(tmp_path, out, **fields)
    capsys.readouterr()
    assert run("report", copy, "--out", tmp_path / "re", "--no-pdf") == 2
    assert not (tmp_path / "re").exists()
    return capsys.readouterr().err.splitlines()


def _says(tmp_path: Path, field: str, given: str, made: str) -> str:
    return (
        f"error: {tmp_path / 'in' / 'summary.json'}: $.acceptance.{field} {given}, but its "
        f"{made}: the summary's batch decision is not that of these results (inspect again, or "
        "name the results files without the summary)"
    )


def test_the_summaries_inspect_writes_are_re_rendered(failing, passing, tmp_path) -> None:
    for out in (failing, passing):
        s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        assert s["acceptance"]["decision"] == ("fail" if out is failing else "pass")
        for lang in ("en", "zh"):
            assert run("report", out, "--out", tmp_path / out.parent.name / lang, "--no-pdf") == 0


def test_a_pass_decision_over_a_failing_sampled_block_is_refused(failing, tmp_path, capsys):
    err = _refused(tmp_path, capsys, failing, decision="pass")
    assert err == [
        _says(tmp_path, "decision", 'is "pass"', 'blocks\' results files make it "fail"')
    ]


def test_a_failing_sampled_block_left_out_of_the_failing_list_is_refused(failing, tmp_path, capsys):
    err = _refused(tmp_path, capsys, failing, failing=[])
    made = 'blocks\' results files make it ["F3-B01"]'
    assert err == [_says(tmp_path, "failing", "lists []", made)]


def test_an_unsampled_failing_block_left_out_of_the_returned_list_is_refused(
    failing, tmp_path, capsys
):
    err = _refused(tmp_path, capsys, failing, returned=[])
    made = 'blocks\' results files make it ["F3-B02"]'
    assert err == [_says(tmp_path, "returned", "lists []", made)]


def test_a_blocks_grade_other_than_its_results_file_is_refused(failing, tmp_path, capsys):
    s = json.loads((failing / "summary.json").read_text(encoding="utf-8"))
    blocks = s["acceptance"]["blocks"]
    blocks[0] = {**blocks[0], "grade": "good"}
    err = _refused(tmp_path, capsys, failing, blocks=blocks)
    made = 'results file makes it "excellent"'
    assert err == [_says(tmp_path, "blocks[0] (F1-B01) grade", 'is "good"', made)]


@pytest.mark.parametrize(
    ("field", "value", "made"),
    [
        ("batch_grade", "good", '"excellent"'),
        ("better_pct", 80.0, "100.0"),
        ("top_pct", 50.0, "100.0"),
        ("sample_grade", "good", '"excellent"'),
    ],
)
def test_another_batch_grade_or_share_is_refused(passing, tmp_path, capsys, field, value, made):
    err = _refused(tmp_path, capsys, passing, **{field: value})
    given = f"is {json.dumps(value)}"
    assert err == [_says(tmp_path, field, given, f"blocks' results files make it {made}")]


def test_another_mean_score_is_refused(passing, tmp_path, capsys) -> None:
    s = json.loads((passing / "summary.json").read_text(encoding="utf-8"))
    mean = s["acceptance"]["mean_score"]
    err = _refused(tmp_path, capsys, passing, mean_score=90.0)
    made = f"blocks' results files make it {json.dumps(mean)}"
    assert err == [_says(tmp_path, "mean_score", "is 90.0", made)]


def test_a_sample_other_than_the_blocks_carrying_checkpoints_is_refused(passing, tmp_path, capsys):
    err = _refused(tmp_path, capsys, passing, sample=["F1-B01"])
    made = 'blocks\' results files make it ["F1-B01", "F2-B01", "F4-B01"]'
    assert err == [_says(tmp_path, "sample", 'is ["F1-B01"]', made)]


def test_a_decision_left_out_over_evaluated_blocks_is_refused(failing, tmp_path, capsys):
    copy = tmp_path / "in"
    shutil.copytree(failing, copy)
    s = json.loads((copy / "summary.json").read_text(encoding="utf-8"))
    (copy / "summary.json").write_text(json.dumps({**s, "acceptance": None}), encoding="utf-8")
    assert run("report", copy, "--out", tmp_path / "re", "--no-pdf") == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: {copy / 'summary.json'}: $.acceptance is null, but its blocks' results files "
        "are evaluated (block F1-B01): the batch decision is left out (inspect again)"
    ]


def _block_edited(tmp_path: Path, out: Path, block: str, edit: Any) -> Path:
    """A copy of one block's results file with its evaluation changed by `edit`."""
    copy = tmp_path / "in" / block
    shutil.copytree(out / block, copy)
    doc = json.loads((copy / "results.json").read_text(encoding="utf-8"))
    edit(doc["evaluation"])
    (copy / "results.json").write_text(json.dumps(doc), encoding="utf-8")
    return copy / "results.json"


def _block_refused(tmp_path: Path, capsys, out: Path, edit: Any) -> list[str]:
    path = _block_edited(tmp_path, out, "F3-B01", edit)
    capsys.readouterr()
    assert run("report", path, "--out", tmp_path / "re", "--no-pdf") == 2
    assert not (tmp_path / "re").exists()
    return [line.removeprefix(f"error: {path}: ") for line in capsys.readouterr().err.splitlines()]


def test_an_evaluation_score_its_elements_do_not_make_is_refused(failing, tmp_path, capsys):
    """F3-B01: data 20 (basis 100 × .2; plane, height and edge 0 with their A-class errors),
    layout 100, attachment 100: .6·20 + .2·100 + .2·100 = 52. A score edited to 95 was
    re-rendered as the block's."""
    err = _block_refused(tmp_path, capsys, failing, lambda ev: ev.update(score=95.0))
    assert err == ["$.evaluation.score is 95.0, but its elements make it 52.0 (inspect again)"]


def test_an_item_score_its_record_does_not_make_is_refused(failing, tmp_path, capsys):
    """The edge item holds RO-3's A-class error: 0, whatever its accuracy scores. Edited to 94.7,
    its element's 20 is no longer the weighted mean of its items either:
    (.2·100 + .3·0 + .3·0 + .2·94.7) / 1 = 38.94."""

    def edit(ev: dict[str, Any]) -> None:
        ev["elements"][0]["items"][3]["score"] = 94.7

    assert _block_refused(tmp_path, capsys, failing, edit) == [
        "$.evaluation.elements[0].items[3] (edge_accuracy).score is 94.7, but its record makes "
        "it 0.0 (inspect again)",
        "$.evaluation.elements[0] (data).score is 20.0, but its items make 38.94 (inspect again)",
    ]


def test_a_block_with_a_class_errors_said_not_to_fail_is_refused(failing, tmp_path, capsys):
    err = _block_refused(tmp_path, capsys, failing, lambda ev: ev.update(fails=False))
    assert err == [
        "$.evaluation.fails is false, but the block has element data below 60: it fails "
        "(§QE-2) (inspect again)"
    ]


def test_the_evaluations_inspect_writes_are_re_rendered_alone(failing, tmp_path) -> None:
    for block in ("F1-B01", "F3-B01", "F3-B02"):
        assert run("report", failing / block, "--out", tmp_path / block, "--no-pdf") == 0


def test_the_decision_pages_show_what_each_a_class_error_misses(failing, tmp_path) -> None:
    """F3-B02 is returned for RO-3: its plane discrepancy 36.42 m against the tolerance 2√2·m
    = 2·1.4142·10 = 28.28 m. The pages said '36.42 (fails its threshold)' alone."""
    summary = (failing / "summary.html").read_text(encoding="utf-8")
    assert "RO-3 Plane 36.42 m (fails its threshold: &lt; 28.28 m)" in summary
    assert run("report", failing, "--out", tmp_path / "zh", "--lang", "zh", "--no-pdf") == 0
    for page in ("summary.html", "acceptance.html"):
        text = (tmp_path / "zh" / page).read_text(encoding="utf-8")
        assert "RO-3 平面 36.42 m（超出限值：&lt; 28.28 m）" in text


def test_a_grade_its_score_does_not_make_is_refused(failing, tmp_path, capsys):
    """A block that fails (§QE-2) is graded fail whatever its score; one that does not takes the
    first grade its score reaches (§QE-5: excellent ≥ 90). An edited grade was shown on the
    block report beside the score ('52.0 — Excellent')."""

    def excellent(ev: dict[str, Any]) -> None:
        ev.update(grade="excellent", grade_title="Excellent", grade_title_zh="优")

    assert _block_refused(tmp_path, capsys, failing, excellent) == [
        '$.evaluation.grade is "excellent", but the block fails (§QE-2), so fail by '
        "global-project's grades (inspect again)"
    ]
    path = _block_edited(tmp_path / "2", failing, "F1-B01", lambda ev: ev.update(grade="good"))
    score = json.loads(path.read_text(encoding="utf-8"))["evaluation"]["score"]
    assert score >= 90
    capsys.readouterr()
    assert run("report", path, "--out", tmp_path / "re2", "--no-pdf") == 2
    assert capsys.readouterr().err.splitlines() == [
        f'error: {path}: $.evaluation.grade is "good", but the block scores {score}: excellent '
        "by global-project's grades (inspect again)"
    ]


def test_the_signature_lines_of_the_chinese_acceptance_page_take_a_full_width_colon(
    failing, tmp_path
) -> None:
    """acceptance.html in Chinese read '编写: Li Wei' (an ASCII colon and a space), where the
    block report and every other label of the page read '编写：'."""
    assert run("report", failing, "--out", tmp_path / "zh", "--lang", "zh", "--no-pdf") == 0
    text = (tmp_path / "zh" / "acceptance.html").read_text(encoding="utf-8")
    for label in ("编写", "审核", "批准"):
        assert f"{label}：" in text and f"{label}: " not in text
    assert run("report", failing, "--out", tmp_path / "en", "--no-pdf") == 0
    assert "Prepared by: " in (tmp_path / "en" / "acceptance.html").read_text(encoding="utf-8")


def test_the_source_of_the_sample_is_bracketed_in_the_pages_language(failing, tmp_path) -> None:
    """The Chinese pages read 'F1-B01, F2-B01, F3-B01, F4-B01 (带检查点的区域网（未给出抽样方案）)':
    ASCII brackets around Chinese text holding full-width ones."""
    assert run("report", failing, "--out", tmp_path / "zh", "--lang", "zh", "--no-pdf") == 0
    for page in ("summary.html", "acceptance.html"):
        text = (tmp_path / "zh" / page).read_text(encoding="utf-8")
        assert (
            'F1-B01、F2-B01、F3-B01、F4-B01<span class="note">'
            "（带检查点的区域网（未给出抽样方案））</span>" in text
        )
    text = (failing / "summary.html").read_text(encoding="utf-8")
    assert (
        'F1-B01, F2-B01, F3-B01, F4-B01<span class="note"> (the blocks that carry checkpoints '
        "(no sampling plan given))</span>" in text
    )


def test_a_sampled_block_with_rules_failed_is_listed_in_the_decision_section(tmp_path) -> None:
    """One simulated block on a 2×2 grid of 20 observations per scene fails TP-4 (class C) and
    TP-5 (class D): its evaluation passes (no A-class error, no element below 60), so the sample
    passes. summary.html's decision section said 'Accepted (pass)' without naming the block or
    its rules failed, as acceptance.html and the blocks returned for correction do; its grade
    is shown as a pass, not in the colour of a failure."""
    batch, out = tmp_path / "batch", tmp_path / "out"
    args = ("--fields", "1", "--blocks-per-field", "1", "--grid", "2x2", "--obs-per-scene", "20")
    assert run_blockqc("simulate", batch, *args, "--seed", "1").returncode == 0
    (tmp_path / "v.yaml").write_text(VERDICTS, encoding="utf-8")
    p = run_blockqc("inspect", batch, "--verdicts", tmp_path / "v.yaml", "--out", out, "--no-pdf")
    assert p.returncode == 1, p.stderr
    decision = json.loads((out / "summary.json").read_text(encoding="utf-8"))["acceptance"]
    assert decision["decision"] == "pass" and decision["blocks"][0]["failed_rules"] == [
        "TP-4",
        "TP-5",
    ]
    for lang, title, rules in (
        ("en", "Sampled blocks with rules failed that do not fail the sample (1)", "TP-4, TP-5"),
        ("zh", "有规则未通过但不致样本不合格的样本单位（1）", "TP-4、TP-5"),
    ):
        assert run("report", out, "--out", tmp_path / lang, "--lang", lang, "--no-pdf") == 0
        page = (tmp_path / lang / "summary.html").read_text(encoding="utf-8")
        section = page.split('<section id="decision-section">', 1)[1].split("</section>", 1)[0]
        assert title in section and '<td class="id">F1-B01</td>' in section and rules in section
        assert 'class="status fail"' not in section
