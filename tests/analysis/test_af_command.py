"""`blockqc factors`: from deliveries and DEM tiles, and from a table, to CSV, JSON, plots, page."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from blockqc.analysis.command import command
from blockqc.errors import InputError, Problem, UsageError

SAMPLES = Path(__file__).resolve().parents[2] / "samples"


class _Tags(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)


@pytest.fixture(scope="module")
def batch(tmp_path_factory, make_block):
    root = tmp_path_factory.mktemp("batch")
    make_block(root, "F1-B01", 40.27, 39.60, 3, 300, 1, ["2023-03-01", "2023-03-02"])
    make_block(root, "F1-B02", 40.30, 39.62, 4, 500, 2, ["2023-04-01"])
    make_block(root, "F2-B01", 40.40, 39.60, 3, 200, 3, ["2023-05-01", "2023-06-01"])
    return root


def test_batch_with_dem_folder(batch, data_dir, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(command, [str(batch), "--dem", str(data_dir), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "CCA not computed" in res.output
    table = pd.read_csv(out / "experiments.csv")
    assert list(table["experiment"]) == ["F1-B01", "F1-B02", "F2-B01"]
    assert list(table["images_number"]) == [3, 4, 3]
    assert list(table["images_periods"]) == [2, 1, 2]
    assert list(table["tp_number"]) == [300, 500, 200]
    # 4 scenes 0.06° wide every 0.04°: union 0.18°, seen twice 3 × 0.02°
    assert table.loc[1, "overlap_degree"] == pytest.approx(0.06 / 0.18, rel=1e-3)
    # F2-B01 spans lon 40.40–40.54; the DEM crop ends at 40.45
    assert table.loc[2, "dem_coverage"] == pytest.approx(0.05 / 0.14, abs=0.01)
    assert table.loc[0, "dem_coverage"] == pytest.approx(1.0)
    # the blocks covered in part are named, the one covered in full is not:
    # F1-B02 spans 40.30–40.48, covered to 40.45: 0.15 / 0.18 = 83 %
    warnings = [x for x in res.output.splitlines() if x.startswith("warning:")]
    assert warnings == [
        "warning: F1-B02: the DEM covers 83 % of its footprint (terrain from that part)",
        "warning: F2-B01: the DEM covers 36 % of its footprint (terrain from that part)",
    ]
    assert (table["mean_slope_deg"] > 1).all() and (table["l_rmse_px"] < 1).all()
    results = json.loads((out / "factors.json").read_text(encoding="utf-8"))
    assert results["cca"] is None
    assert any("n = 3" in r and "17" in r for r in results["cca_not_computed"])
    corr = pd.read_csv(out / "correlation.csv", index_col=0)
    assert corr.shape == (10, 5)
    page = (out / "factors.html").read_text(encoding="utf-8")
    assert "CCA not computed" in page and "at least 17 rows" in page
    assert "<svg" in page and "Pearson" in page and "F2-B01" in page
    assert (out / "correlation.svg").stat().st_size > 0
    assert not (out / "structure.svg").exists()


def test_table_mode_full_analysis(appendix, appendix_path, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(command, ["--table", str(appendix_path), "--out", str(out)])
    assert res.exit_code == 0, res.output
    results = json.loads((out / "factors.json").read_text(encoding="utf-8"))
    x = appendix.iloc[:, 4:14].to_numpy(float)
    y = appendix.iloc[:, 14:19].to_numpy(float)
    r = np.corrcoef(np.hstack([x, y]), rowvar=False)
    m = np.linalg.solve(r[:10, :10], r[:10, 10:]) @ np.linalg.solve(r[10:, 10:], r[10:, :10])
    r1 = np.sqrt(np.max(np.linalg.eigvals(m).real))
    assert results["cca"]["tests"][0]["canonical_correlation"] == pytest.approx(r1, abs=1e-8)
    tests = pd.read_csv(out / "cca_tests.csv")
    assert list(tests["df"]) == [50, 36, 24, 14, 6]
    struct = pd.read_csv(out / "cca_structure.csv")
    assert len(struct) == 15 and set(struct["group"]) == {"factor", "indicator"}
    coef = pd.read_csv(out / "cca_coefficients.csv")
    assert list(coef.columns) == ["group", "variable"] + [f"pair_{k}" for k in range(1, 6)]
    page = (out / "factors.html").read_text(encoding="utf-8")
    parser = _Tags()
    parser.feed(page)
    assert parser.tags.count("svg") == 2 and "table" in parser.tags
    assert "Bartlett" in page and "CCA not computed" not in page
    for name in ("correlation.png", "structure.png", "structure.svg", "experiments.csv"):
        assert (out / name).stat().st_size > 0


def test_page_escapes_text(appendix, tmp_path):
    t = appendix.copy()
    t["region"] = t["region"].astype(str)
    t.loc[0, "region"] = "<script>alert(1)</script>"
    src = tmp_path / "t.csv"
    t.to_csv(src, index=False)
    out = tmp_path / "out"
    assert CliRunner().invoke(command, ["--table", str(src), "--out", str(out)]).exit_code == 0
    page = (out / "factors.html").read_text(encoding="utf-8")
    assert "<script>" not in page and "&lt;script&gt;" in page


def test_errors(appendix_path, batch, tmp_path):
    with pytest.raises(UsageError, match="either BATCH"):
        command.main(["--out", str(tmp_path / "o")], standalone_mode=False)
    with pytest.raises(UsageError, match="needs --dem"):
        command.main([str(batch), "--out", str(tmp_path / "o")], standalone_mode=False)
    with pytest.raises(UsageError, match="never writes into a delivery"):
        command.main(
            [str(batch), "--dem", str(tmp_path), "--out", str(batch / "x")], standalone_mode=False
        )
    linked = tmp_path / "linked"  # a batch whose delivery is a link to a folder elsewhere
    linked.mkdir()
    (linked / "F1-B01").symlink_to(batch / "F1-B01")
    out = batch / "F1-B01" / "x"
    with pytest.raises(UsageError) as err:
        command.main(
            [str(linked), "--dem", str(tmp_path), "--out", str(out)], standalone_mode=False
        )
    assert str(err.value) == (
        f"--out {out} lies inside the delivery {batch / 'F1-B01'}: blockqc never writes into a "
        "delivery; choose an output folder outside it"
    )
    assert not out.exists()
    bad = tmp_path / "bad.csv"
    bad.write_text(
        appendix_path.read_text(encoding="utf-8").replace("0.4761", "x"), encoding="utf-8"
    )
    with pytest.raises(InputError) as err:
        command.main(["--table", str(bad), "--out", str(tmp_path / "o")], standalone_mode=False)
    assert [(p.row, p.column) for p in err.value.problems] == [(1, "overlap_degree")]


@pytest.mark.skipif(
    not (SAMPLES / "batch").is_dir(), reason="samples/batch is made by the sample generator"
)
def test_sample_batch_page(tmp_path):
    """The shipped sample batch on the shipped DEM tiles: factors for every block, a readable
    page with the correlation matrix and the reason the CCA is not computed."""
    out = tmp_path / "out"
    args = [str(SAMPLES / "batch"), "--dem", str(SAMPLES / "dem"), "--out", str(out)]
    res = CliRunner().invoke(command, args)
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out / "experiments.csv")
    assert len(table) >= 8
    assert (table["dem_coverage"] > 0.5).all()
    assert table["mean_slope_deg"].between(1, 45).all()
    assert table["tp_nn_coefficient"].between(0.2, 2.2).all()
    results = json.loads((out / "factors.json").read_text(encoding="utf-8"))
    assert results["correlation"] is not None
    page = (out / "factors.html").read_text(encoding="utf-8")
    parser = _Tags()
    parser.feed(page)
    assert "svg" in parser.tags
    if results["cca"] is None:
        assert "CCA not computed" in page and "at least 17 rows" in page


def test_a_stereo_iou_given_is_recorded_with_the_options(batch, data_dir, tmp_path):
    """A finite --stereo-iou in (0, 1] is taken (NaN is refused: tests/test_cli_options.py)."""
    out = tmp_path / "out"
    args = [str(batch), "--dem", str(data_dir), "--stereo-iou", "1", "--out", str(out)]
    res = CliRunner().invoke(command, args)
    assert res.exit_code == 0, res.output
    results = json.loads((out / "factors.json").read_text(encoding="utf-8"))
    assert results["options"]["stereo_iou"] == 1.0


def test_a_dem_that_covers_no_block_is_refused(batch, dem_writer, tmp_path):
    far = dem_writer(tmp_path / "far.tif", np.full((50, 50), 100.0), 10.0, 60.0, 0.01, "EPSG:4326")
    out = tmp_path / "out"
    with pytest.raises(UsageError, match="covers none of the blocks"):
        args = [str(batch), "--dem", str(far), "--out", str(out)]
        command.main(args, standalone_mode=False)
    assert not (out / "experiments.csv").exists()


def test_an_output_that_would_replace_the_table_is_refused(appendix_path, tmp_path):
    folder = tmp_path / "d"
    folder.mkdir()
    table = folder / "experiments.csv"
    table.write_bytes(appendix_path.read_bytes())
    with pytest.raises(UsageError) as err:
        command.main(["--table", str(table), "--out", str(folder)], standalone_mode=False)
    assert err.value.exit_code == 2
    assert f"its experiments.csv would replace the input {table}" in str(err.value)
    assert table.read_bytes() == appendix_path.read_bytes()
    assert sorted(p.name for p in folder.iterdir()) == ["experiments.csv"]
    # the table's own folder is fine when no output takes its name
    mine = folder / "mine.csv"
    table.rename(mine)
    res = CliRunner().invoke(command, ["--table", str(mine), "--out", str(folder)])
    assert res.exit_code == 0, res.output
    assert mine.read_bytes() == appendix_path.read_bytes()


def test_outputs_of_an_earlier_run_are_removed(appendix_path, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(command, ["--table", str(appendix_path), "--out", str(out)])
    assert res.exit_code == 0, res.output
    (out / "notes.txt").write_text("mine", encoding="utf-8")
    one = tmp_path / "one.csv"
    one.write_text("\n".join(appendix_path.read_text().splitlines()[:2]) + "\n")
    res = CliRunner().invoke(command, ["--table", str(one), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == [
        "experiments.csv",
        "factors.html",
        "factors.json",
        "notes.txt",
    ]


def test_a_refused_batch_leaves_no_output_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    args = [str(tmp_path / "empty"), "--dem", str(tmp_path), "--out", str(tmp_path / "o")]
    with pytest.raises(InputError, match="neither a delivery"):
        command.main(args, standalone_mode=False)
    assert not (tmp_path / "o").exists()


def test_empty_out_is_refused(appendix_path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(command, ["--table", str(appendix_path), "--out", ""])
    assert res.exit_code == 2
    assert "Invalid value for '--out': an empty path: give an output folder" in res.output
    assert list(tmp_path.iterdir()) == []


def test_help_says_where_out_may_be():
    """docs/factors.md: --out may be the folder of --table (not "never inside an input")."""
    text = " ".join(CliRunner().invoke(command, ["--help"]).output.split())
    assert (
        "Output folder: never inside BATCH; it may be the folder of --table unless one of its "
        "outputs would replace the table." in text
    )


def test_a_failure_after_out_is_made_leaves_no_empty_folder(appendix_path, tmp_path, monkeypatch):
    """The run stops once --out is made (here the analysis, made to fail): the folder the run
    made is removed again, one that was there before is kept."""
    import blockqc.analysis.command as factors_command

    def fail(*args, **kwargs):
        raise InputError(Problem(file="table.csv", message="cannot be analysed"))

    monkeypatch.setattr(factors_command, "analyse", fail)
    out = tmp_path / "out"
    args = ["--table", str(appendix_path), "--out", str(out)]
    with pytest.raises(InputError, match="cannot be analysed"):  # exit 2
        command.main(args, standalone_mode=False)
    assert not out.exists()
    out.mkdir()
    with pytest.raises(InputError):
        command.main(args, standalone_mode=False)
    assert out.is_dir()


def test_a_template_that_fails_on_the_analysis_leaves_no_output(appendix_path, tmp_path):
    """The page is rendered before any file is written: a user's template that fails on the
    results (an undefined name) left the CSVs, JSON and figures of a run without its page."""
    from blockqc.cli import main

    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "factors.html.j2").write_text("{{ no_such_name }}\n", encoding="utf-8")
    (mine / "block.html.j2").write_text("{{ x | num }}\n")  # a report page: not the factors'
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(
            ["factors", "--table", str(appendix_path), "--out", str(out), "--templates", str(mine)]
        )
    assert exc.value.code == 2 and not out.exists()


def test_a_factors_template_that_cannot_be_read_is_named(appendix_path, tmp_path):
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "factors.html.j2").write_text("ok\n{{ 1 | no_such_filter }}\n", encoding="utf-8")
    args = ["--table", str(appendix_path), "--out", str(tmp_path / "o"), "--templates", str(mine)]
    with pytest.raises(InputError) as err:
        command.main(args, standalone_mode=False)
    assert str(err.value) == (
        f"{mine / 'factors.html.j2'}, line 2: not a readable template: No filter named "
        "'no_such_filter'."
    )
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "options", [["--dem", "{table}"], ["--overlap", "union", "--edge-correction"]]
)
def test_options_of_a_batch_are_refused_with_a_table(appendix_path, tmp_path, options):
    """--table gives the experiments table itself: the options that build it from deliveries
    would be ignored, so they are refused by name (exit 2), nothing written."""
    out = tmp_path / "out"
    options = [o.format(table=appendix_path) for o in options]  # an existing file for --dem
    result = CliRunner().invoke(
        command, ["--table", str(appendix_path), "--out", str(out), *options]
    )
    assert isinstance(result.exception, UsageError), result.output
    named = [o for o in options if o.startswith("--")]
    assert str(result.exception).startswith(f"{', '.join(named)}: options that build the table")
    assert not out.exists()


@pytest.mark.parametrize("lang", ["en", "zh"])
def test_one_row_gives_the_rows_the_cca_needs(appendix_path, tmp_path, lang):
    """A table of one row said only "the table has 1 complete rows"; it now says, as for any
    count below p + q + 2 = 17, what the CCA needs (and no column is called constant, though
    every column of one row is)."""
    table = tmp_path / "one.csv"
    lines = appendix_path.read_text(encoding="utf-8").splitlines()[:2]
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(command, ["--table", str(table), "--out", str(out), "--lang", lang])
    assert res.exit_code == 0, res.output
    # the console said "1 of 1 experiments analysed", silent on the correlations, none computed
    assert res.output.startswith(
        "1 of 1 experiments analysed (10 factors x 5 indicators); no correlation computed "
        "(fewer than 3 values, no correlation: mean_elevation_m, mean_slope_deg, "
    )
    assert "h_rmse_m); CCA not computed: the table has n = 1 complete rows" in res.output
    results = json.loads((out / "factors.json").read_text(encoding="utf-8"))
    assert results["cca_not_computed"] == [
        "the table has n = 1 complete rows but CCA of p = 10 factors and q = 5 indicators needs "
        "n − 1 > p + q, i.e. at least 17 rows (with fewer, some canonical correlation is 1 by "
        "construction and Bartlett's statistic is undefined)"
    ]
    page = (out / "factors.html").read_text(encoding="utf-8")
    said = {"en": "at least 17 rows", "zh": "表中有 n = 1 个完整的行，但 p = 10 个因素"}[lang]
    assert said in page and "constant" not in results["cca_not_computed"][0]
