"""`blockqc report`: re-rendering from results.json alone; bad input is exit 2 with no traceback."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from report_helpers import make_summary, results_entry

from blockqc.cli import main
from blockqc.report import write_block_report


def run(*args: str) -> int:
    with pytest.raises(SystemExit) as exc:
        main(list(args))
    return exc.value.code


def test_report_command_rerenders_the_same_content(tmp_path, results_file, results_doc, capsys):
    direct = tmp_path / "direct"
    write_block_report(direct, results_doc, pdf=False)
    assert run("report", str(results_file), "--out", str(tmp_path / "out"), "--no-pdf") == 0
    again = tmp_path / "out" / "T-B01"
    assert sorted(p.name for p in again.iterdir()) == [
        "checkpoints.csv",
        "evidence.csv",
        "report.html",
        "results.json",
    ]
    for name in ("report.html", "checkpoints.csv", "evidence.csv"):
        assert (again / name).read_bytes() == (direct / name).read_bytes(), name
    assert (again / "results.json").read_bytes() == results_file.read_bytes()
    assert "T-B01" in capsys.readouterr().out


def test_report_command_takes_a_folder_and_chinese(tmp_path, results_file):
    assert (
        run(
            "report",
            str(results_file.parent),
            "--out",
            str(tmp_path / "zh"),
            "--lang",
            "zh",
            "--no-pdf",
        )
        == 0
    )
    html = (tmp_path / "zh" / "T-B01" / "report.html").read_text(encoding="utf-8")
    assert "验收报告" in html and "不合格" in html


def test_report_command_rerenders_a_batch_summary(tmp_path, results_doc):
    batch = tmp_path / "batch"
    (batch / "T-B01").mkdir(parents=True)
    (batch / "T-B01" / "results.json").write_text(json.dumps(results_doc), encoding="utf-8")
    summary = make_summary([results_entry(results_doc)])
    (batch / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    assert run("report", str(batch / "summary.json"), "--out", str(tmp_path / "o"), "--no-pdf") == 0
    assert (tmp_path / "o" / "summary.html").is_file()
    assert (tmp_path / "o" / "T-B01" / "report.html").is_file()


def test_no_pdf_leaves_no_pdf_of_an_earlier_run_behind(tmp_path, results_doc):
    """An earlier run's PDFs would give what the re-rendered results may no longer say."""
    batch = tmp_path / "batch"
    (batch / "T-B01").mkdir(parents=True)
    (batch / "T-B01" / "results.json").write_text(json.dumps(results_doc), encoding="utf-8")
    summary = make_summary([results_entry(results_doc)])
    (batch / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    out = tmp_path / "o"
    (out / "T-B01").mkdir(parents=True)
    for old in ("T-B01/report.pdf", "summary.pdf", "acceptance.pdf", "acceptance.html"):
        (out / old).write_bytes(b"%PDF-1.7 an earlier run's")
    assert run("report", str(batch / "summary.json"), "--out", str(out), "--no-pdf") == 0
    assert not (out / "T-B01" / "report.pdf").exists()
    assert not (out / "summary.pdf").exists() and not (out / "acceptance.pdf").exists()
    assert not (out / "acceptance.html").exists()  # the summary has no acceptance section


def test_summary_links_the_pdfs_the_rerendering_leaves(tmp_path, results_doc):
    """A batch inspected with PDFs, re-rendered without: its summary linked the PDFs just
    removed. The summary.json and page written say which blocks have a PDF now."""
    batch = tmp_path / "batch"
    (batch / "T-B01").mkdir(parents=True)
    (batch / "T-B01" / "results.json").write_text(json.dumps(results_doc), encoding="utf-8")
    summary = make_summary([results_entry(results_doc, pdf=True)])
    (batch / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    out = tmp_path / "o"
    assert run("report", str(batch), "--out", str(out), "--no-pdf") == 0
    assert not (out / "T-B01" / "report.pdf").exists()
    written = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [b["pdf"] for b in written["blocks"]] == [False]
    assert "report.pdf" not in (out / "summary.html").read_text(encoding="utf-8")
    assert json.loads((batch / "summary.json").read_text(encoding="utf-8")) == summary


@pytest.mark.parametrize(
    "content, expected",
    [
        ('{"block_id": "X",\n  "verdict": }', "line 2"),
        ('{"block_id": "X", "value": NaN}', "NaN is not JSON"),
        ('{"block_id": "X", "value": -Infinity}', "-Infinity is not JSON"),
        ("[1, 2, 3]", "at $: Input should be a valid dictionary"),
        ('{"block_id": "X", "rule_pack": "p", "results": []}', "at $.verdict: Field required"),
        (
            '{"block_id": "X", "rule_pack": "p", "verdict": "pass", "results": [{"rule": "A"}]}',
            "at $.results[0].status: Field required",
        ),
        (
            '{"block_id": "X", "rule_pack": "p", "verdict": "pass", "results": '
            '[{"rule": "A", "title": "a", "clause": "§A", "status": "passed"}]}',
            "at $.results[0].status: Input should be 'pass'",
        ),
    ],
)
def test_bad_input_is_exit_2_naming_the_file(tmp_path, capsys, content, expected):
    bad = tmp_path / "results.json"
    bad.write_text(content, encoding="utf-8")
    assert run("report", str(bad), "--out", str(tmp_path / "out"), "--no-pdf") == 2
    err = capsys.readouterr().err
    assert str(bad) in err and expected in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_missing_input_is_exit_2(tmp_path, capsys):
    assert run("report", str(tmp_path / "nothing"), "--out", str(tmp_path / "o")) == 2
    assert "does not exist" in capsys.readouterr().err


def test_a_results_file_linking_to_nothing_is_said_to_be_such_a_link(tmp_path, capsys, results_doc):
    """A results.json given as a symbolic link whose file was moved was said not to exist,
    and one inside a folder given (its results.json, a block's */results.json) was not named
    at all: the folder 'holds no results.json', or its other blocks rendered alone (exit 0).
    Each is now said to be a link to nothing, naming where it leads."""
    linked = tmp_path / "results.json"
    linked.symlink_to(tmp_path / "moved.json")
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "results.json").symlink_to(tmp_path / "gone.json")
    batch = tmp_path / "batch"
    (batch / "T-B01").mkdir(parents=True)
    (batch / "T-B01" / "results.json").write_text(json.dumps(results_doc), encoding="utf-8")
    (batch / "T-B00").mkdir()
    (batch / "T-B00" / "results.json").symlink_to(tmp_path / "lost.json")
    for given, link, target in (
        (linked, linked, "moved.json"),
        (folder, folder / "results.json", "gone.json"),
        (batch, batch / "T-B00" / "results.json", "lost.json"),
    ):
        assert run("report", str(given), "--out", str(tmp_path / "o"), "--no-pdf") == 2
        err = capsys.readouterr().err
        why = f"error: {link}: a symbolic link to {tmp_path / target}, which does not exist"
        assert why in err.splitlines(), err
        assert "holds no results.json" not in err
        assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_inspection_run_and_rerender_give_the_same_report(tmp_path):
    """A simulated block through the engine, then `blockqc report` on its results.json."""
    exe = [str(Path(sys.executable).parent / "blockqc")]
    subprocess.run(
        [
            *exe,
            "simulate",
            str(tmp_path / "d"),
            "--fields",
            "3",
            "--blocks-per-field",
            "1",
            "--grid",
            "3x3",
            "--obs-per-scene",
            "120",
        ],
        check=True,
        capture_output=True,
    )
    rc = subprocess.run(
        [*exe, "inspect", str(tmp_path / "d"), "--out", str(tmp_path / "a")],
        capture_output=True,
        text=True,
    )
    assert rc.returncode in (0, 1), rc.stderr
    first = next((tmp_path / "a").glob("*/results.json"))
    inspected = first.parent / "report.html"
    rc = subprocess.run(
        [*exe, "report", str(first), "--out", str(tmp_path / "b"), "--no-pdf"],
        capture_output=True,
        text=True,
    )
    assert rc.returncode == 0, rc.stderr
    again = tmp_path / "b" / first.parent.name / "report.html"
    assert again.read_text(encoding="utf-8") == inspected.read_text(encoding="utf-8")


@pytest.mark.parametrize("where", [".", "x", "x/y"])
def test_out_inside_an_input_folder_is_refused(tmp_path, capsys, results_file, where):
    block = results_file.parent
    before = sorted(p.name for p in block.iterdir())
    out = block / where
    for named in (block, results_file):
        assert run("report", str(named), "--out", str(out), "--no-pdf") == 2
        assert capsys.readouterr().err == (
            f"error: --out {out} lies inside the input folder {block}: choose an output folder "
            "outside the inputs (or, to re-render in place, the folder that holds "
            "<block_id>/results.json)\n"
        )
    assert sorted(p.name for p in block.iterdir()) == before


def test_rerendering_in_place_is_allowed(tmp_path, results_file):
    """docs/report.md: the results files are copied only when the output folder is another one;
    --out the folder holding <block_id>/results.json re-renders beside them."""
    raw = results_file.read_bytes()
    batch = results_file.parents[1]
    assert run("report", str(batch), "--out", str(batch), "--no-pdf") == 0
    assert (results_file.parent / "report.html").is_file()
    assert results_file.read_bytes() == raw
    assert sorted(p.name for p in batch.iterdir()) == ["T-B01"]


def test_empty_out_is_refused(tmp_path, capsys, results_file, monkeypatch):
    monkeypatch.chdir(tmp_path / "in")
    assert run("report", str(results_file), "--out", "", "--no-pdf") == 2
    assert "Invalid value for '--out': an empty path: give an output folder" in (
        capsys.readouterr().err
    )
    assert sorted(p.name for p in results_file.parent.iterdir()) == ["results.json"]
    assert sorted(p.name for p in (tmp_path / "in").iterdir()) == ["T-B01"]


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        (
            {"block.html.j2": "<p>\n{{ results.block_id </p>\n"},
            "{d}/block.html.j2, line 2: not a readable template: unexpected '/'",  # `<` an operator
        ),
        (
            {"block.html.j2": "{{ results.block_id | no_such_filter }}\n"},
            "{d}/block.html.j2, line 1: not a readable template: No filter named 'no_such_filter'.",
        ),
        (
            {"block.html.j2": '{% include "_mine.html.j2" %}\n'},
            "{d}/block.html.j2, line 1: _mine.html.j2: no such template, in the folder or the "
            "stock ones",
        ),
        (
            {"block.html.j2": '<p>\n{% include ["_a.html.j2", "_b.html.j2"] %}\n'},
            "{d}/block.html.j2, line 2: _a.html.j2 or _b.html.j2: no such template, in the folder "
            "or the stock ones",
        ),
        (
            {"block.html.j2": '{% include "_mine.html.j2" %}\n', "_mine.html.j2": "{% if x %}\n"},
            "{d}/_mine.html.j2, line 1: not a readable template: Unexpected end of template.",
        ),
    ],
)
def test_a_template_that_cannot_be_read_is_named_before_anything_runs(
    tmp_path, results_file, capsys, files, expected
):
    """It used to be found block after block, each block then 'could not be inspected'."""
    mine = tmp_path / "templates"
    mine.mkdir()
    for name, text in files.items():
        (mine / name).write_text(text, encoding="utf-8")
    (mine / "factors.html.j2").write_text("{{ 1 | num }}\n")  # the factors page's filter: left
    out = tmp_path / "out"
    assert run("report", str(results_file), "--out", str(out), "--templates", str(mine)) == 2
    assert capsys.readouterr().err.startswith("error: " + expected.format(d=mine))
    assert not out.exists()


def test_a_template_jinja_may_leave_out_or_choose_is_not_refused(tmp_path, results_file):
    """`ignore missing` and a list of choices (the first there taken) render as Jinja renders
    them: they were refused as no such template, when one named could not be found."""
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "block.html.j2").write_text(
        '{% include "_none.html.j2" ignore missing %}'
        '{% include ["_none.html.j2", "_mine.html.j2"] %}\n',
        encoding="utf-8",
    )
    (mine / "_mine.html.j2").write_text("<p>{{ r.block_id }}</p>\n", encoding="utf-8")
    out = tmp_path / "out"
    assert run("report", str(results_file), "--out", str(out), "--no-pdf", "--templates", mine) == 0
    assert (out / "T-B01" / "report.html").read_text(encoding="utf-8") == "<p>T-B01</p>"


def test_a_template_that_fails_on_the_results_is_an_error_not_an_internal_one(
    tmp_path, results_file, capsys
):
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "block.html.j2").write_text("{{ no_such_name }}\n", encoding="utf-8")
    out = tmp_path / "out"
    assert run("report", str(results_file), "--out", str(out), "--no-pdf", "--templates", mine) == 2
    assert capsys.readouterr().err == (
        f"error: {mine / 'block.html.j2'}, line 1: a template fails: UndefinedError: "
        "'no_such_name' is undefined\n"
    )


def test_a_results_file_named_twice_is_rendered_once_with_a_warning(tmp_path, results_file, capsys):
    """As inspect does for a delivery named twice: said, not silently folded."""
    again = results_file.parent / ".." / "T-B01" / "results.json"  # the same file, spelt apart
    out = tmp_path / "out"
    args = [str(results_file), str(results_file), str(again), str(results_file.parent)]
    assert run("report", *args, "--out", str(out), "--no-pdf") == 0
    captured = capsys.readouterr()
    warned = [x for x in captured.err.splitlines() if x.startswith("warning:")]
    assert warned == [
        f"warning: {results_file}: named more than once, rendered once",
        f"warning: {again}: named more than once, rendered once",
    ]
    assert captured.out.count("T-B01        FAIL") == 1


def test_two_batch_summaries_are_refused(tmp_path, results_doc, capsys):
    """The second replaced the first unsaid: one summary listed one batch's blocks only."""
    summaries = []
    for batch, bid in (("a", "T-B01"), ("b", "T-B02")):
        (tmp_path / batch / bid).mkdir(parents=True)
        doc = {**results_doc, "block_id": bid}
        (tmp_path / batch / bid / "results.json").write_text(json.dumps(doc), encoding="utf-8")
        summary = make_summary([results_entry(doc)])
        summaries.append(tmp_path / batch / "summary.json")
        summaries[-1].write_text(json.dumps(summary), encoding="utf-8")
    out = tmp_path / "o"
    assert run("report", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(out)) == 2
    assert (
        f"{summaries[1]}: a second batch summary (the first: {summaries[0]}): re-render one "
        "batch at a time, or name the results files without their summaries"
    ) in capsys.readouterr().err
    assert not out.exists()


def test_out_inside_a_delivery_is_refused(tmp_path, results_file, capsys):
    """report reads results files, not deliveries, but writes into no delivery either."""
    delivery = tmp_path / "F1-B01"
    delivery.mkdir()
    (delivery / "block.yaml").write_text("block_id: F1-B01\n", encoding="utf-8")
    out = delivery / "reports"
    assert run("report", str(results_file), "--out", str(out), "--no-pdf") == 2
    assert capsys.readouterr().err == (
        f"error: --out {out} lies inside the delivery {delivery}: blockqc never writes into a "
        "delivery; choose an output folder outside it\n"
    )
    assert sorted(p.name for p in delivery.iterdir()) == ["block.yaml"]


def test_block_folder_that_is_a_delivery_is_refused(tmp_path, results_file, capsys):
    """results.json copied into its delivery and re-rendered "in place": <out>/<block_id> is
    the delivery, whose checkpoints.csv the export would replace. Refused, nothing written."""
    block_id = json.loads(results_file.read_text(encoding="utf-8"))["block_id"]
    delivery = tmp_path / block_id
    delivery.mkdir()
    (delivery / "block.yaml").write_text(f"block_id: {block_id}\n", encoding="utf-8")
    (delivery / "checkpoints.csv").write_text("the producer's table\n", encoding="utf-8")
    shutil.copy(results_file, delivery / "results.json")
    assert run("report", str(delivery / "results.json"), "--out", str(tmp_path), "--no-pdf") == 2
    assert f"the outputs of block {block_id} would go into {delivery}, a delivery" in (
        capsys.readouterr().err
    )
    assert sorted(p.name for p in delivery.iterdir()) == [
        "block.yaml",
        "checkpoints.csv",
        "results.json",
    ]
    assert (delivery / "checkpoints.csv").read_text(encoding="utf-8") == "the producer's table\n"


@pytest.fixture(scope="module")
def batch_out(tmp_path_factory) -> Path:
    """summary.json and results of two sample blocks, as inspect writes them."""
    out = tmp_path_factory.mktemp("batch") / "out"
    samples = Path(__file__).parents[2] / "samples" / "batch"
    assert run("inspect", str(samples / "F1-B01"), str(samples / "F1-B02"), "--out", str(out),
               "--pdf", "none") in (0, 1)  # fmt: skip
    return out


def _tampered(batch_out: Path, tmp_path: Path, edit) -> Path:
    out = Path(shutil.copytree(batch_out, tmp_path / "in"))
    doc = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    edit(doc)
    (out / "summary.json").write_text(json.dumps(doc), encoding="utf-8")
    return out


def test_a_summary_that_is_not_its_blocks_is_refused(batch_out, tmp_path, capsys):
    """A block left out of summary.json (its counts still of two), or a block whose results
    file says otherwise than the summary: the page would show a batch that is not the one
    inspected. Refused, naming the counts and the block; the untouched summary re-renders."""
    assert run("report", str(batch_out), "--out", str(tmp_path / "ok"), "--no-pdf") == 0
    capsys.readouterr()
    fewer = _tampered(batch_out, tmp_path, lambda d: d["blocks"].pop())
    assert run("report", str(fewer / "summary.json"), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    err = capsys.readouterr().err
    assert f"{fewer / 'summary.json'}: $.counts.blocks is 2, but its blocks make it 1" in err
    assert not (tmp_path / "o").exists()

    def other(d):
        d["blocks"][0]["verdict"] = "fail"
        d["counts"].update({"pass": d["counts"]["pass"] - 1, "fail": d["counts"]["fail"] + 1})

    shutil.rmtree(fewer)
    changed = _tampered(batch_out, tmp_path, other)
    assert run("report", str(changed), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    assert "lists block F1-B01 as fail, with counts" in capsys.readouterr().err


def test_a_summary_whose_verdict_is_not_its_blocks_is_refused(batch_out, tmp_path, capsys):
    """Both blocks pass, the summary says fail (or the other way round): the page showed the
    summary's word in colour over counts that contradict it."""
    wrong = _tampered(batch_out, tmp_path, lambda d: d.update(verdict="fail"))
    assert run("report", str(wrong), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    assert (
        f"{wrong / 'summary.json'}: $.verdict is fail, but its blocks make it pass (0 failing, "
        "0 unreadable)" in capsys.readouterr().err
    )
    assert not (tmp_path / "o").exists()


def test_results_without_any_rule_result_are_refused(tmp_path, results_doc, capsys):
    """No rule judged: the page said PASS over nothing."""
    empty = tmp_path / "results.json"
    doc = {**results_doc, "results": [], "verdict": "pass"}
    doc["counts"] = dict.fromkeys(doc["counts"], 0)
    empty.write_text(json.dumps(doc), encoding="utf-8")
    assert run("report", str(empty), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    assert f"{empty}: $.results is empty" in capsys.readouterr().err


def _edit(doc, metric, table, row, key, value):
    m = next(m for m in doc["measurements"] if m["metric"] == metric)
    i = doc["measurements"].index(m)
    if value is None:
        del m["tables"][table][row][key]
    else:
        m["tables"][table][row][key] = value
    return f"$.measurements[{i}].tables.{table}[{row}]"


@pytest.mark.parametrize(
    ("metric", "table", "key", "value", "expected"),
    [
        ("checkpoint_accuracy", "point", "error_m", "abc", ".error_m: expected a number or null"),
        ("checkpoint_accuracy", "point", "x_m", "east", ".x_m: expected a number or null"),
        ("checkpoint_accuracy", "point", "point_id", None, ": no point_id"),
        ("checkpoint_accuracy", "component_method", "norm_m", "ten", ".norm_m: expected a number"),
        ("tie_point_distribution", "scene", "scene_id", None, ": no scene_id"),
    ],
)
def test_measurement_values_the_figures_draw_are_checked(
    tmp_path, results_doc, capsys, metric, table, key, value, expected
):
    """A hand-edited table the figures draw (a checkpoint's error written as text, a row without
    its id) was an internal error (ValueError: could not convert string to float: 'abc'); it is
    refused with the field named, exit status 2, nothing written."""
    at = _edit(results_doc, metric, table, 0, key, value)
    path = tmp_path / "results.json"
    path.write_text(json.dumps(results_doc), encoding="utf-8")
    assert run("report", str(path), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    err = capsys.readouterr().err
    assert f"{path}: {at}{expected}" in err and "internal error" not in err
    assert not (tmp_path / "o").exists()


def test_a_scene_map_point_or_histogram_count_written_as_text_is_refused(
    tmp_path, results_doc, capsys
):
    """The scene maps' points and the histogram's counts are numbers too."""
    distribution = next(
        m for m in results_doc["measurements"] if m["metric"] == "tie_point_distribution"
    )
    scene = next(iter(distribution["failing_scene_points"]))
    distribution["failing_scene_points"][scene]["line"][3] = "12"
    errors = next(m for m in results_doc["measurements"] if m["metric"] == "tie_point_errors")
    errors["detail"]["histogram"]["counts"][0] = None
    path = tmp_path / "results.json"
    path.write_text(json.dumps(results_doc), encoding="utf-8")
    assert run("report", str(path), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    err = capsys.readouterr().err
    assert f".failing_scene_points.{scene}.line[3]: expected a number, not '12'" in err
    assert ".detail.histogram.counts[0]: expected a number, not None" in err


def test_a_summary_naming_a_block_by_another_id_is_refused(batch_out, tmp_path, capsys):
    """A block renamed in summary.json (its results file still F1-B01's): the page would list
    a block no results file is of."""

    def rename(d):
        d["blocks"][0]["block_id"] = "ZZZ"

    renamed = _tampered(batch_out, tmp_path, rename)
    assert run("report", str(renamed), "--out", str(tmp_path / "o"), "--no-pdf") == 2
    assert (
        "lists block ZZZ with the results file F1-B01/results.json, which is block F1-B01's"
        in capsys.readouterr().err
    )


def test_a_template_no_page_has_is_warned_of(tmp_path, results_file, capsys):
    """A misspelt block.html.j2 in --templates would be left unused and the stock page
    rendered without a word: it is named, with the template it resembles."""
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "blok.html.j2").write_text("{{ r.block_id }}\n", encoding="utf-8")
    out = tmp_path / "out"
    assert run("report", str(results_file), "--out", str(out), "--no-pdf", "--templates", mine) == 0
    assert (
        f"warning: {mine / 'blok.html.j2'}: no page of blockqc has this template, not used "
        "(did you mean block.html.j2?)"
    ) in capsys.readouterr().err


def _failing_on(tmp_path: Path, page: str, when: str) -> Path:
    """Templates whose `page` fails (an undefined name) where `when` holds."""
    mine = tmp_path / "templates"
    mine.mkdir()
    stock = (Path(__file__).parents[2] / "templates" / page).read_text(encoding="utf-8")
    (mine / page).write_text(f"{{% if {when} %}}{{{{ no_such_name }}}}{{% endif %}}" + stock)
    return mine


def test_a_template_failing_on_one_block_leaves_no_page_written(batch_out, tmp_path, capsys):
    """The blocks rendered before it kept their new pages, and the failing block its copied
    results.json without a report; the summary was not written. Every page is now made apart
    and put in place only when all are: nothing is written, the folder made is removed."""
    mine = _failing_on(tmp_path, "block.html.j2", "r.block_id == 'F1-B02'")
    out = tmp_path / "o"
    args = ("report", str(batch_out), "--out", str(out), "--no-pdf", "--templates", str(mine))
    assert run(*args) == 2
    assert "'no_such_name' is undefined" in capsys.readouterr().err
    assert not out.exists()


def test_a_summary_template_failing_in_place_leaves_the_pages_as_they_were(
    batch_out, tmp_path, capsys
):
    """Re-rendered in place in Chinese, the blocks' pages were rewritten before the summary's
    template failed: English summary, Chinese blocks. They are now left as they were."""
    out = Path(shutil.copytree(batch_out, tmp_path / "in"))
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    mine = _failing_on(tmp_path, "summary.html.j2", "true")
    args = ("report", str(out), "--out", str(out), "--no-pdf", "--lang", "zh")
    assert run(*args, "--templates", str(mine)) == 2
    assert "'no_such_name' is undefined" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert run(*args) == 0  # and without the failing template, made in place as before
    assert "验收报告" in (out / "F1-B01" / "report.html").read_text(encoding="utf-8")
    assert (out / "F1-B01" / "results.json").read_bytes() == before[out / "F1-B01" / "results.json"]
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == []


def test_a_file_where_a_block_folder_goes_is_refused_before_anything_is_written(
    batch_out, tmp_path, capsys
):
    """The blocks before it were written, then the run stopped on "File exists"; it is now
    named, and nothing is written."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "F1-B02").write_text("not a folder", encoding="utf-8")
    assert run("report", str(batch_out), "--out", str(out), "--no-pdf") == 2
    assert (
        f"error: {out / 'F1-B02'}: a file where the outputs of block F1-B02 go"
        in capsys.readouterr().err
    )
    assert sorted(p.name for p in out.iterdir()) == ["F1-B02"]
    assert (out / "F1-B02").read_text(encoding="utf-8") == "not a folder"


def test_a_reader_that_stops_reading_stops_no_rendering(batch_out, tmp_path):
    """`blockqc report OUT --out DIR | head -1`: the line after the reader had gone raised
    a broken pipe between two blocks put in place, and the run stopped with exit 1 (click's,
    for a broken pipe); the others were not written. It now goes on, silent: exit 0, all
    written."""
    read, write = os.pipe()
    os.close(read)  # a reader gone before the first line
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "blockqc", "report", str(batch_out), "--out", str(out),
           "--no-pdf"]  # fmt: skip
    proc = subprocess.run(cmd, stdout=write, stderr=subprocess.PIPE, text=True, timeout=600)
    os.close(write)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert sorted(p.parent.name for p in out.glob("*/report.html")) == ["F1-B01", "F1-B02"]
    assert (out / "summary.html").is_file()


def test_an_unknown_key_of_a_results_file_is_named_with_the_key_it_resembles(tmp_path, capsys):
    """A key misspelt in a results.json edited by hand was refused as pydantic words it ('Extra
    inputs are not permitted'), where every other file of blockqc says 'unknown key' and the
    key meant."""
    doc = {
        "block_id": "X",
        "rule_pack": "p",
        "verdcit": "pass",
        "results": [{"rule": "A", "title": "a", "clause": "§A", "status": "pass", "zzz": 1}],
    }
    bad = tmp_path / "results.json"
    bad.write_text(json.dumps(doc), encoding="utf-8")
    assert run("report", str(bad), "--out", str(tmp_path / "out"), "--no-pdf") == 2
    said = f"error: {bad}: not a valid results.json: at "
    assert capsys.readouterr().err.splitlines() == [
        f"{said}$.verdict: Field required",
        f"{said}$.results[0].zzz: unknown key (not in the schema of results.json: blockqc "
        "schema results)",
        f"{said}$.verdcit: unknown key; did you mean 'verdict'?",
    ]


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (  # saved from an editor in the Chinese locale's encoding
            '{\n  "block_id": "X",\n  "inspector": "李伟"\n}'.encode("gbk"),
            "line 3: byte 0xc0 at character 17 is not UTF-8: the file must be UTF-8 text (it "
            "looks like GBK / GB18030; save it as UTF-8)",
        ),
        (  # UTF-16 without its byte order mark was said to be no valid JSON
            '{"block_id": "X"}'.encode("utf-16-le"),
            "line 1: every other byte is NUL (0x00): the file must be UTF-8 text (it looks like "
            "UTF-16LE without a byte order mark; save it as UTF-8)",
        ),
    ],
)
def test_a_results_file_not_in_utf8_is_said_as_every_other_file_is(
    tmp_path, capsys, data, expected
):
    """A results.json in another encoding was refused as 'is not UTF-8 text (byte 28)': no line,
    no character, no guess at the encoding, which blockqc's other files are told with."""
    bad = tmp_path / "results.json"
    bad.write_bytes(data)
    assert run("report", str(bad), "--out", str(tmp_path / "out"), "--no-pdf") == 2
    assert capsys.readouterr().err.splitlines() == [f"error: {bad}, {expected}"]
