"""`where:` on a column of fixed values (a scene's band, a checkpoint statistic's name) is
checked against them as a group's is: `band: PAN` selects no scene (bands are `pan`, `ms`),
and the rule would be not applicable on every delivery, which then passes it unjudged."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.errors import RuleError
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import extension_pack

RULE = """\
rules:
  - id: PA-1
    title: At least 100 tie points in every scene
    clause: §TP-4
    content: tp_number
    metric: tie_point_distribution
    params: {bands: [pan, ms]}
    scope: scene
    where: {band: ms}
    statistic: n_points
    threshold: {min: 100}
    unit: points
"""

CP_RULE = """\
rules:
  - id: PA-2
    title: Plane mean error within 8 m
    clause: §CP-7
    content: cp_plane
    metric: checkpoint_accuracy
    scope: component_method
    where: {component: plane, statistic: mean}
    statistic: medium_error
    threshold: {max: 8}
    unit: m
"""


@pytest.mark.parametrize(
    ("body", "old", "new", "message"),
    [
        (RULE, "{band: ms}", "{band: MS}", "where.band: no band 'MS' (did you mean ms?)"),
        (
            RULE,
            "    unit: points\n",
            "    unit: points\n    evidence_where: {band: Pan}\n",
            "evidence_where.band: no band 'Pan' (did you mean pan?)",
        ),
        (CP_RULE, "statistic: mean}", "statistic: M3}", "where.statistic: no statistic 'M3'"),
    ],
)
def test_a_value_the_column_never_takes_is_refused_at_its_line(
    tmp_path: Path, body: str, old: str, new: str, message: str
) -> None:
    path = extension_pack(tmp_path, body.replace(old, new))
    with pytest.raises(RuleError) as exc:
        load_pack(path)
    (problem,) = exc.value.problems
    assert problem.file == str(path)
    line = path.read_text("utf-8").splitlines()[problem.line - 1]
    assert message.split("'")[1] in line  # the line giving the value
    assert message in problem.message


def test_a_value_the_column_takes_selects_its_units(tmp_path: Path) -> None:
    """The case delivery's MS scene M1 holds no tie point: 0 < 100, the one unit judged."""
    pack = load_pack(extension_pack(tmp_path, RULE))
    delivery = load_delivery(write_delivery(tmp_path / "delivery"))
    (pa1,) = [r for r in inspect_delivery(delivery, pack).results if r.rule == "PA-1"]
    assert pa1.status == "fail"
    assert pa1.value == 0
    assert pa1.detail["n_units"] == 1
    assert [e["scene_id"] for e in pa1.evidence] == ["M1"]
