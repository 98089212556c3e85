"""A rule over the sampled blocks' checkpoints is of the detailed inspection (DOMAIN §2) when it
does not say `inspection:`. A project rule on checkpoint_accuracy written as the README's
examples are (no `inspection:`) was of the general inspection: under a sampling plan it judged
the checkpoints of blocks not sampled, and returned them for correction (a gross-error rate of
1 in 27, 3.7 %, above a project's 3 %), where CP-1..CP-5 are not applicable there."""

from __future__ import annotations

from pathlib import Path

import pytest

from blockqc.acceptance.plan import NOT_SAMPLED, apply_plan
from blockqc.delivery import load_delivery
from blockqc.engine import inspect_delivery
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from casekit import extension_pack

GROSS = """\
  - id: PR-1
    title: Gross-error rate below 3 %
    clause: §CP-6
    content: {cp_plane: {component: plane}, cp_height: {component: height}}
    metric: checkpoint_accuracy
    scope: component_method
    statistic: gross_rate
    threshold: {max: 3, inclusive: false}
    unit: "%"
"""
COVERAGE = """\
  - id: PR-2
    title: Reference coverage
    clause: §CP-2
    content: [cp_plane, cp_height]
    metric: reference_coverage
    statistic: conforms
    threshold: {equals: true}
  - id: PR-3
    title: RMSE within 5 m
    clause: §CP-5
    content: cp_plane
    metric: asprs_accuracy
    scope: component
    where: {component: horizontal}
    statistic: rmse_m
    threshold: {max: 5}
    unit: m
  - id: PR-4
    title: Median tie-point error
    clause: §TP-1
    content: ro_report
    metric: tie_point_errors
    statistic: median
    threshold: {max: 0.4}
    unit: px
"""


def test_rules_over_checkpoints_are_detailed_unless_they_say_otherwise(tmp_path: Path) -> None:
    pack = load_pack(extension_pack(tmp_path, "rules:\n" + GROSS + COVERAGE))
    got = {r.id: r.inspection for r in pack.rules if r.id.startswith("PR-")}
    assert got == {"PR-1": "detailed", "PR-2": "detailed", "PR-3": "detailed", "PR-4": "general"}
    general = GROSS.replace("    metric:", "    inspection: general\n    metric:")
    pack = load_pack(extension_pack(tmp_path, "rules:\n" + general, name="other"))
    assert pack.rule("PR-1").inspection == "general"


@pytest.mark.parametrize(("sampled", "status"), [(True, "fail"), (False, "not_applicable")])
def test_a_block_not_sampled_is_not_judged_on_its_checkpoints(
    tmp_path: Path, sampled: bool, status: str
) -> None:
    """The base delivery's 27 high-precision checkpoints with C00's height 6.5 m off: beyond
    2·m = 6 m of a 3 m norm, one gross error in 27 (3.7 %), not below 3 %."""
    body = "constants:\n  norm: {height_m: 3}\nrules:\n" + GROSS
    pack = load_pack(extension_pack(tmp_path, body))
    block = write_delivery(
        tmp_path / "delivery",
        {"set": {"checkpoints": [{"where": {"point_id": "C00"}, "values": {"ref_z_m": 43.5}}]}},
    )
    results = apply_plan(inspect_delivery(load_delivery(block), pack), sampled=sampled)
    height = [r for r in results.results if r.rule == "PR-1" and r.group["component"] == "height"]
    assert [r.status for r in height] == [status]
    if sampled:
        assert height[0].value == pytest.approx(100 / 27)
    else:
        assert height[0].detail["reason"] == NOT_SAMPLED
