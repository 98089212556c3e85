"""`blockqc rules lint` on the `acceptance:` section: values scoring cannot use, at their line."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.errors import RuleError
from blockqc.rules import load_pack
from casekit import extension_pack as _pack
from casekit import lint_messages as _messages

ITEMS = (
    "mathematical_basis, plane_accuracy, height_accuracy, edge_accuracy, points_distribution, "
    "report, documents"
)


def test_unknown_weight_key_is_named_at_its_line(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path, "acceptance:\n  weights:\n    items: {report: 0.7, documents: 0.3, reprot: 1}\n"
    )
    assert _messages(pack) == [
        f"{pack}, line 5: acceptance.weights.items: 'reprot' is no item (did you mean report?); "
        f"the items: {ITEMS}"
    ]


def test_unknown_weight_key_is_named_in_the_file_that_writes_it(tmp_path: Path) -> None:
    parent = _pack(tmp_path, "acceptance:\n  weights:\n    elements: {dta: 1}\n", "parent")
    child = _pack(tmp_path, "acceptance:\n  deduction: {B: 10}\n", "child", "parent.yaml")
    assert _messages(child) == [
        f"{parent}, line 5: acceptance.weights.elements: 'dta' is no element (did you mean "
        "data?); the elements: data, layout, attachment"
    ]


def test_an_element_weighted_among_the_items_is_refused_saying_where_it_belongs(
    tmp_path: Path,
) -> None:
    """items: {data: 0} was taken and read by nothing: the data element kept its 0.6."""
    pack = _pack(tmp_path, "acceptance:\n  weights:\n    items: {data: 0}\n")
    assert _messages(pack) == [
        f"{pack}, line 5: acceptance.weights.items: 'data' is no item (it is one of the "
        f"elements); the items: {ITEMS}"
    ]


def test_element_weights_all_zero_are_refused(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path, "acceptance:\n  weights:\n    elements: {data: 0, layout: 0, attachment: 0}\n"
    )
    assert _messages(pack) == [
        f"{pack}, line 5: acceptance.weights.elements: every weight of the quality elements "
        "(data, layout, attachment) is 0: their score Σwᵢsᵢ/Σwᵢ is undefined; give at least one "
        "a weight above 0"
    ]
    with pytest.raises(RuleError):
        load_pack(pack)


def test_item_weights_of_one_element_all_zero_are_refused(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "acceptance:\n  weights:\n    items:\n      report: 0\n      documents: 0\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 6: acceptance.weights.items: every weight of the items of element "
        "attachment (report, documents) is 0: their score Σwᵢsᵢ/Σwᵢ is undefined; give at least "
        "one a weight above 0"
    ]


def test_some_zero_weights_are_fine(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path,
        "acceptance:\n  weights:\n    elements: {layout: 0}\n    items: {report: 0}\n",
    )
    assert _messages(pack) == []


def test_a_norm_of_zero_is_refused_at_its_line(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "overrides:\n  CP-2:\n    score: {kind: accuracy, norm: 0}\n")
    assert _messages(pack) == [
        f"{pack}, line 5: rule CP-2: score.norm: the norm m0 divides the accuracy score: "
        "expected above 0, got 0"
    ]


def test_a_norm_expression_at_or_below_zero_is_refused(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path, "overrides:\n  CP-2:\n    score: {kind: accuracy, norm: norm.plane_m - 12}\n"
    )
    assert _messages(pack) == [
        f"{pack}, line 5: rule CP-2: score.norm is -2: m0 divides the accuracy score (§QE-3): "
        "give a norm above 0"
    ]


def test_an_upper_bound_standing_for_the_norm_must_be_above_zero(tmp_path: Path) -> None:
    pack = _pack(
        tmp_path, "overrides:\n  TP-1:\n    score: {kind: accuracy}\n    threshold: {max: 0}\n"
    )
    assert _messages(pack) == [
        f"{pack}, line 6: rule TP-1: score: the norm m0 is threshold.max, 0: m0 divides the "
        "accuracy score (§QE-3): give a norm above 0, or give score.norm"
    ]


def test_an_accuracy_score_without_norm_needs_an_upper_bound(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "overrides:\n  TP-4:\n    score: {kind: accuracy}\n")
    assert _messages(pack) == [
        f"{pack}, line 5: rule TP-4: score: without score.norm the norm m0 is the upper bound, "
        "and threshold has no max: give score.norm"
    ]


def test_a_sampling_table_whose_sample_falls_is_refused(tmp_path: Path) -> None:
    """`sample: 2` for 20 (a digit lost) drew 2 blocks of a batch of 250 and passed lint."""
    pack = _pack(
        tmp_path,
        "acceptance:\n  sampling:\n    table:\n      - {batch: 232, sample: 17}\n"
        "      - {batch: 282, sample: 2}\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 5: acceptance.sampling.table: row 2: batches of up to 282 give a "
        "sample of 2, below the 17 of batches of up to 232 (row 1): the sample grows with the "
        "batch (a digit missing?)"
    ]


def test_rows_out_of_order_and_grades_out_of_order_are_said_at_once(tmp_path: Path) -> None:
    """Each was said alone, at the line of `acceptance:` or `sampling:`, the other only once
    the first was put right."""
    pack = _pack(
        tmp_path,
        "acceptance:\n  grades:\n    - {id: excellent, min: 90, title: Excellent}\n"
        "    - {id: good, min: 95, title: Good}\n    - {id: pass, min: 60, title: Pass}\n"
        "  sampling:\n    table:\n      - {batch: 20, sample: 3}\n"
        "      - {batch: 10, sample: 3}\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 9: acceptance.sampling.table: row 2 (batch 10) follows row 1 (batch "
        "20): batch sizes must be strictly ascending",
        f"{pack}, line 4: acceptance.grades: list them best first, each lowest score below the "
        "one before (of two grades from the same score the second would never be given): got "
        "excellent 90, good 95, pass 60",
    ]


def test_a_number_written_as_true_false_or_text_is_refused_at_its_line(tmp_path: Path) -> None:
    """`sample: yes` is not a sample of 1, `B: true` not a deduction of 1 point, "20" not 20:
    each is refused where it is written, saying what was expected; 40.0 says to write 40."""
    pack = _pack(
        tmp_path,
        "acceptance:\n"
        "  sampling:\n"
        "    table:\n"
        "      - {batch: 20, sample: yes}\n"  # line 6
        '      - {batch: "40", sample: 5}\n'
        "      - {batch: 60.0, sample: 7}\n"
        "  deduction: {B: true}\n"  # line 9
        "  batch_grades:\n"
        "    - {grade: excellent, better_pct: '90', top_pct: 50}\n"  # line 11
        "  weights:\n"
        "    elements: {data: false}\n",  # line 13
    )
    assert _messages(pack) == [
        f"{pack}, line 6: acceptance.sampling.table.0.sample: expected a whole number, got "
        "true/false (true)",
        f"{pack}, line 7: acceptance.sampling.table.1.batch: expected a whole number, got text "
        "'40'",
        f"{pack}, line 8: acceptance.sampling.table.2.batch: expected a whole number, got 60.0 "
        "(write 60)",
        f"{pack}, line 9: acceptance.deduction.B: expected a number, got true/false (true)",
        f"{pack}, line 11: acceptance.batch_grades.0.better_pct: expected a number, got text '90'",
        f"{pack}, line 13: acceptance.weights.elements.data: expected a number, got true/false "
        "(false)",
    ]
    with pytest.raises(RuleError):
        load_pack(pack)


def test_an_element_or_item_added_without_a_weight_is_refused_where_it_is_added(
    tmp_path: Path,
) -> None:
    """A project element without a weight was weighted 1 beside data .6, layout .2 and
    attachment .2 (half of the block's score); an item added to data, 1 beside .2/.3/.3/.2."""
    pack = _pack(
        tmp_path,
        "elements:\n"
        "  - id: data\n"  # line 4
        "    title: Data quality\n"
        "    items:\n"
        "      - id: timing\n"  # line 7
        "        title: Timing\n"
        "        contents: [{id: acquisition_dates, title: Acquisition dates}]\n"
        "  - id: metadata\n"  # line 10
        "    title: Metadata quality\n"
        "    items:\n"
        "      - id: metadata_files\n"
        "        title: Metadata files\n"
        "        contents: [{id: md_complete, title: Complete}]\n",
    )
    assert _messages(pack) == [
        f"{pack}, line 10: element metadata: no weight under acceptance.weights.elements, "
        "beside data 0.6, layout 0.2, attachment 0.2 (the quality elements): it would be "
        "weighted 1; give it one (0: not counted)",
        f"{pack}, line 7: item timing: no weight under acceptance.weights.items, beside "
        "mathematical_basis 0.2, plane_accuracy 0.3, height_accuracy 0.3, edge_accuracy 0.2 "
        "(the items of element data): it would be weighted 1; give it one (0: not counted)",
    ]
    weighted = _pack(
        tmp_path,
        pack.read_text().split("\n", 2)[2]
        + "acceptance:\n  weights:\n    elements: {metadata: 0.1}\n    items: {timing: 0}\n",
        name="weighted",
    )
    assert _messages(weighted) == []


BASIS_LEFT_OUT = "give at least one document, or leave the key out"


def test_an_empty_basis_of_a_pack_is_refused_at_its_line(tmp_path: Path) -> None:
    """A pack extending the stock pack with `basis: []` had acceptance.html say its inspection
    basis was 'not given', the stock pack's three documents dropped, and rules lint said 'ok'.
    Refused at its line, as a --meta file's `basis: []` is."""
    pack = _pack(tmp_path, "acceptance:\n  basis: []\n  basis_zh: []\n")
    assert _messages(pack) == [
        f"{pack}, line 4: acceptance.basis: {BASIS_LEFT_OUT} to use the basis of the pack it "
        "extends",
        f"{pack}, line 5: acceptance.basis_zh: {BASIS_LEFT_OUT} to use the basis_zh of the pack "
        "it extends",
    ]
    with pytest.raises(RuleError):
        load_pack(pack)


def test_an_empty_basis_is_said_in_the_file_of_the_chain_that_writes_it(tmp_path: Path) -> None:
    parent = _pack(tmp_path, "acceptance:\n  basis_zh: []\n", "parent")
    child = _pack(tmp_path, "acceptance:\n  deduction: {B: 10}\n", "child", "parent.yaml")
    assert _messages(child) == [
        f"{parent}, line 4: acceptance.basis_zh: {BASIS_LEFT_OUT} to use the basis_zh of the "
        "pack it extends"
    ]


def test_an_empty_basis_of_a_pack_extending_none_is_refused(tmp_path: Path) -> None:
    """The stock pack's text with its basis emptied: no pack to take one from."""
    stock = (Path(__file__).parents[2] / "rules" / "global-project.yaml").read_text("utf-8")
    lines = stock.splitlines()
    at = lines.index("  basis:")
    end = next(i for i in range(at + 1, len(lines)) if not lines[i].startswith("    - "))
    lines[at:end] = ["  basis: []"]
    pack = tmp_path / "root.yaml"
    pack.write_text("\n".join(lines).replace("pack: global-project", "pack: root"), "utf-8")
    said = [m for m in _messages(pack) if "acceptance.basis" in m]
    assert said == [
        f"{pack}, line {at + 1}: acceptance.basis: {BASIS_LEFT_OUT} and give the basis in the "
        "--meta file"
    ]


def test_a_packs_own_basis_is_taken(tmp_path: Path) -> None:
    pack = _pack(tmp_path, "acceptance:\n  basis: [Design of the project]\n")
    assert _messages(pack) == []
    assert load_pack(pack).acceptance.basis == ["Design of the project"]
