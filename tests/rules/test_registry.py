"""Metrics declare the scopes they offer; the rule language checks a rule against them."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
import yaml

from blockqc.delivery import load_delivery
from blockqc.engine import Context, names_for
from blockqc.errors import RuleError
from blockqc.metrics import REGISTRY, MetricSpec, NoParams, Scope, Table, metric
from blockqc.metrics import Measurement as M
from blockqc.metrics.reference import markdown_reference
from blockqc.resources import rules_dir
from blockqc.rules import load_pack
from blockqc.rules.casebase import write_delivery
from blockqc.rules.lint import NOT_NUMBER_UNITS
from blockqc.verification import prepare

DOCS = Path(__file__).resolve().parents[2] / "docs" / "metrics.md"


@pytest.fixture(scope="module")
def measured(tmp_path_factory) -> dict[str, M]:
    """Every metric the stock pack uses, measured on the base delivery (a figure reported) with
    the contract v1.1 geometry of RC-1's cases and two tie points seen on three scenes."""
    cases = yaml.safe_load((rules_dir() / "global-project.cases" / "RC-1.yaml").read_text("utf-8"))
    folder = tmp_path_factory.mktemp("base") / "CASE"
    edits = {
        "manifest": {"reported": {"tie_point_error_px": 0.3}},
        "files": cases["shared"]["geometry"],
        "append": cases["cases"][0]["append"],
    }
    write_delivery(folder, edits)
    delivery = load_delivery(folder)
    prepare(delivery)
    pack = load_pack("global-project")
    ctx = Context(delivery, names_for(delivery, pack))
    return {r.metric: ctx.measure(r.metric, r.params) for r in pack.rules if not r.manual}


def test_every_metric_is_used_by_a_stock_pack(measured) -> None:
    """The base delivery measures the global-project pack's; the other stock packs' are named."""
    from blockqc.rules import available_packs

    used = {r.metric for ref in available_packs() for r in load_pack(ref).rules if not r.manual}
    assert used == set(REGISTRY)
    assert set(REGISTRY) - set(measured) == {"asprs_accuracy"}  # tested in tests/test_asprs.py


def test_declared_scopes_match_the_tables_measured(measured) -> None:
    for name, m in measured.items():
        spec = REGISTRY[name]
        assert m.not_applicable is None, (name, m.not_applicable)
        assert set(m.tables) == set(spec.scopes), name
        for scope_name, table in m.tables.items():
            scope = spec.scopes[scope_name]
            cols = set(table.df.columns)
            where = f"{name}.{scope_name}"
            assert cols <= set(scope.all_columns()), (where, cols - set(scope.all_columns()))
            assert set(scope.statistics) <= cols, where
            assert set(table.group) == set(scope.groups), where
            assert set(table.keys) == set(scope.keys), where
            for col, values in scope.groups.items():
                assert set(table.df[col].astype(str)) <= set(values), (where, col)


def test_statistics_not_declared_signed_are_never_negative(measured) -> None:
    """Lint refuses a max below 0 on a number not declared `signed`: none measured is below 0."""
    for name, m in measured.items():
        for scope_name, table in m.tables.items():
            scope = REGISTRY[name].scopes[scope_name]
            for stat, unit in scope.statistics.items():
                if unit not in NOT_NUMBER_UNITS and stat not in scope.signed:
                    values = pd.to_numeric(table.df[stat], errors="coerce")
                    assert not (values < 0).any(), (name, scope_name, stat)


def test_a_metric_may_offer_a_scope_of_its_own(monkeypatch, tmp_path: Path) -> None:
    """The rule language fixes no list of scopes: a new metric's `tile` scope is accepted."""
    monkeypatch.setattr("blockqc.metrics.REGISTRY", dict(REGISTRY))
    from blockqc import metrics

    def tiles(d, p, measure) -> M:
        """Tie points per tile."""
        import pandas as pd

        return M({"tile": Table(pd.DataFrame({"tile": ["a"], "n": [3]}), keys=["tile"])})

    metric("tile_counts", params=NoParams, scopes={"tile": Scope({"n": "points"}, keys=("tile",))})(
        tiles
    )
    assert isinstance(metrics.REGISTRY["tile_counts"], MetricSpec)
    monkeypatch.setattr("blockqc.rules.lint.REGISTRY", metrics.REGISTRY)
    pack = tmp_path / "p.yaml"
    rule = (
        "pack: p\nrules:\n  - id: TL-1\n    title: t\n    clause: §TP-4\n"
        "    metric: tile_counts\n    scope: {scope}\n    statistic: n\n    threshold: {{min: 1}}\n"
    )
    pack.write_text(rule.format(scope="tile"), "utf-8")
    assert load_pack(pack).rule("TL-1").scope == "tile"
    pack.write_text(rule.format(scope="tiles"), "utf-8")
    with pytest.raises(RuleError, match="offers no scope 'tiles' \\(did you mean tile\\?\\)"):
        load_pack(pack)


def test_metrics_reference_is_generated_from_the_registry(blockqc) -> None:
    """docs/metrics.md is `blockqc rules metrics --markdown`, regenerated when a metric changes."""
    assert markdown_reference() == DOCS.read_text("utf-8"), (
        "docs/metrics.md is stale: blockqc rules metrics --markdown > docs/metrics.md"
    )
    p = blockqc("rules", "metrics", "--markdown")
    assert p.returncode == 0 and p.stdout == DOCS.read_text("utf-8")
    text = DOCS.read_text("utf-8")
    for name, spec in REGISTRY.items():  # every metric, scope, statistic and parameter listed
        assert f"## `{name}`" in text
        for scope_name, scope in spec.scopes.items():
            assert f"- **{scope_name}** — statistics:" in text
            for stat, unit in scope.statistics.items():
                assert f"`{stat}`" + (f" ({unit})" if unit else "") in text
        for param in spec.params.model_fields:
            assert f"| `{param}` |" in text
    assert "| `plane_norm_m` | float | the pack's `norm.plane_m`, else 10 | m |" in text
