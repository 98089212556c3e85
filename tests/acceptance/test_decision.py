"""§QE-5 batch decision: the sample fails with any failing block, else mean score and grades."""

from __future__ import annotations

import pytest

from blockqc.acceptance.decision import batch_grade, decide
from blockqc.acceptance.model import BlockGrade
from blockqc.rules import load_pack

ACC = load_pack("global-project").acceptance


def blk(i: int, score: float, grade: str, sampled: bool = True, fails: bool = False) -> BlockGrade:
    return BlockGrade(block_id=f"B{i}", sampled=sampled, score=score, grade=grade, fails=fails)


def test_excellent_batch() -> None:
    # mean (95 + 92 + 80)/3 = 89 → sample good; good or better 3/3 = 100 %, excellent 2/3 = 66.7 %
    d = decide([blk(1, 95, "excellent"), blk(2, 92, "excellent"), blk(3, 80, "good")], ACC, "plan")
    assert d.decision == "pass"
    assert d.mean_score == pytest.approx(89)
    assert d.sample_grade == "good"
    assert (d.better_pct, d.top_pct) == (pytest.approx(100), pytest.approx(200 / 3))
    assert d.batch_grade == "excellent"


def test_good_and_pass_batches() -> None:
    # 4 of 5 good or better (80 %), 2 of 5 excellent (40 %) → good
    assert batch_grade(ACC, ["excellent", "excellent", "good", "good", "pass"])[0] == "good"
    # 80 % but 1 of 5 excellent (20 % < 30 %) → pass
    assert batch_grade(ACC, ["excellent", "good", "good", "good", "pass"]) == ("pass", 80, 20)
    # 9 of 10 good or better, 5 excellent → excellent
    assert batch_grade(ACC, ["excellent"] * 5 + ["good"] * 4 + ["pass"])[0] == "excellent"


def test_a_failing_sampled_block_fails_the_batch() -> None:
    blocks = [
        blk(1, 99, "excellent"),
        blk(2, 82, "fail", fails=True),
        blk(3, 70, "fail", sampled=False, fails=True),
    ]
    d = decide(blocks, ACC, "checkpoints")
    assert d.decision == "fail" and d.batch_grade == "fail"
    assert [b.block_id for b in d.failing] == ["B2"]
    assert [b.block_id for b in d.returned] == ["B3"]  # unsampled: returned for correction


def test_unsampled_failures_do_not_decide() -> None:
    d = decide([blk(1, 91, "excellent"), blk(2, 50, "fail", False, True)], ACC, "plan")
    assert (
        d.decision == "pass" and d.mean_score == 91 and [b.block_id for b in d.returned] == ["B2"]
    )


def test_an_unsampled_block_failing_a_rule_is_returned_though_its_grade_passes() -> None:
    """docs/acceptance.md: blocks not sampled that fail their general inspection are returned;
    a rule failed (TP-2: a tie point at 9 px) makes the verdict fail, whatever the score."""
    failed_tp2 = BlockGrade(
        block_id="B2", sampled=False, score=97.3, grade="excellent", failed_rules=["TP-2"]
    )
    d = decide([blk(1, 91, "excellent"), failed_tp2, blk(3, 93, "excellent", False)], ACC, "plan")
    assert d.decision == "pass" and d.mean_score == 91  # the sample decides
    assert [b.block_id for b in d.returned] == ["B2"]


def test_no_sample_is_incomplete() -> None:
    d = decide([blk(1, 91, "excellent", sampled=False)], ACC, "checkpoints")
    assert d.decision == "incomplete" and d.mean_score is None


def test_a_sampled_block_not_read_leaves_the_decision_incomplete() -> None:
    """The plan samples B1 and B2; B2 could not be read: nothing is known of it."""
    d = decide([blk(1, 95, "excellent")], ACC, "plan", ["B2"], ["B1", "B2"])
    assert d.decision == "incomplete" and d.batch_grade is None and d.mean_score is None
    assert d.sample == ["B1", "B2"] and d.unreadable == ["B2"]


def test_a_block_not_sampled_and_not_read_does_not_decide() -> None:
    d = decide([blk(1, 95, "excellent"), blk(2, 80, "good", False)], ACC, "plan", ["B3"], ["B1"])
    assert d.decision == "pass" and d.mean_score == 95 and d.unreadable == ["B3"]


def test_without_a_plan_any_block_not_read_leaves_the_decision_incomplete() -> None:
    """B3 was not read: whether it carries checkpoints, so is of the sample, is not known."""
    d = decide([blk(1, 95, "excellent"), blk(2, 80, "good", False)], ACC, "checkpoints", ["B3"])
    assert d.decision == "incomplete" and d.sample == ["B1"] and d.unreadable == ["B3"]


def test_a_failing_sampled_block_fails_the_batch_whatever_was_not_read() -> None:
    blocks = [blk(1, 95, "excellent"), blk(2, 50, "fail", fails=True)]
    d = decide(blocks, ACC, "plan", ["B3"], ["B1", "B2", "B3"])
    assert d.decision == "fail" and [b.block_id for b in d.failing] == ["B2"]


def test_a_sample_mean_on_a_grade_bound_reaches_it() -> None:
    # nine scores summing to 810: mean 90, so the sample is excellent (§QE-5: ≥ 90)
    scores = [95.68, 84.45, 82.2, 96.43, 81.93, 85.34, 87.57, 97.05, 99.35]
    grades = [ACC.grade(s).id for s in scores]
    d = decide(
        [blk(i, s, g) for i, (s, g) in enumerate(zip(scores, grades, strict=True))], ACC, "plan"
    )
    assert d.mean_score == 90
    assert d.sample_grade == "excellent"
