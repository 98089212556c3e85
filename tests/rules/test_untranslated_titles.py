"""A project rule without `title_zh` showed its English title on the Chinese page, unsaid. The
pack check and a run writing Chinese pages now warn of such rules, once per pack file, naming
them and their lines; no Chinese title is made up."""

from __future__ import annotations

from pathlib import Path

from blockqc.rules import load_pack
from blockqc.rules.lint import untranslated_titles
from casekit import SAMPLES, extension_pack

_RULE = """\
  - id: {rid}
    title: Tie-point RMS within {bound} px
{zh}    clause: §TP-1
    content: ro_report
    metric: tie_point_errors
    params: {{bands: [pan]}}
    statistic: rms
    threshold: {{max: {bound}}}
    unit: px
"""


def _pack(tmp_path: Path, *rules: tuple[str, str]) -> Path:
    """A project pack of rules (id, Chinese title or ''): PR-1 at line 4, each rule 9 lines
    long, a title_zh one line more."""
    body = "".join(
        _RULE.format(rid=rid, bound=0.5 + i / 10, zh=f"    title_zh: {zh}\n" if zh else "")
        for i, (rid, zh) in enumerate(rules)
    )
    return extension_pack(tmp_path, "rules:\n" + body)


def test_the_rules_without_a_chinese_title_are_named_once_with_their_lines(tmp_path) -> None:
    # lines: pack 1, extends 2, rules 3; PR-1 4..12, PR-2 13..22 (with title_zh), PR-3 23..
    pack = _pack(tmp_path, ("PR-1", ""), ("PR-2", "连接点中误差"), ("PR-3", ""))
    assert [str(w) for w in untranslated_titles(load_pack(pack))] == [
        f"{pack}: rules PR-1 (line 4), PR-3 (line 23) have no title_zh: a Chinese page "
        "(--lang zh) shows their English titles; give each a title_zh"
    ]
    one = _pack(tmp_path, ("PR-1", "连接点中误差"), ("PR-2", ""))
    assert [str(w) for w in untranslated_titles(load_pack(one))] == [
        f"{one}, line 14: rule PR-2 has no title_zh: a Chinese page (--lang zh) shows its "
        "English title; give it a title_zh"
    ]


def test_rules_with_chinese_titles_are_not_named(tmp_path) -> None:
    assert untranslated_titles(load_pack("global-project")) == []
    assert untranslated_titles(load_pack("asprs-2023")) == []
    assert untranslated_titles(load_pack(_pack(tmp_path, ("PR-1", "连接点中误差")))) == []


def test_the_pack_check_and_a_chinese_run_warn_an_english_run_does_not(blockqc, tmp_path) -> None:
    pack = _pack(tmp_path, ("PR-1", ""), ("PR-2", ""))
    warning = f"warning: {pack}: rules PR-1 (line 4), PR-2 (line 13) have no title_zh"
    lint = blockqc("rules", "lint", pack)
    assert lint.stderr.count(warning) == 1, lint.stderr
    block = SAMPLES / "batch" / "F1-B01"
    for lang, said in (("zh", 1), ("en", 0)):
        out = tmp_path / f"out-{lang}"
        run = blockqc("inspect", block, "--rules", pack, "--out", out, "--lang", lang, "--no-pdf")
        assert run.returncode == 0, run.stderr
        assert run.stderr.count(warning) == said, run.stderr
    page = (tmp_path / "out-zh" / "F1-B01" / "report.html").read_text("utf-8")
    assert "Tie-point RMS within 0.5 px" in page  # shown as written, not translated


def test_re_rendering_in_chinese_names_them_from_results_json(blockqc, tmp_path) -> None:
    """blockqc report --lang zh writes the Chinese page again from results.json, which keeps no
    rule's line: the rules are named once with the pack and its file."""
    pack = _pack(tmp_path, ("PR-1", ""), ("PR-2", "连接点中误差"))
    block = SAMPLES / "batch" / "F1-B01"
    run = blockqc("inspect", block, "--rules", pack, "--out", tmp_path / "o", "--no-pdf")
    assert run.returncode == 0, run.stderr
    results = tmp_path / "o" / "F1-B01" / "results.json"
    warning = (
        f"warning: {pack}: rule PR-1 has no title_zh (pack project 1): a Chinese page "
        "(--lang zh) shows its English title; give it a title_zh in the pack"
    )
    for lang, said in (("zh", 1), ("en", 0)):
        again = blockqc("report", results, "--out", tmp_path / lang, "--lang", lang, "--no-pdf")
        assert again.returncode == 0, again.stderr
        assert again.stderr.count(warning) == said, again.stderr


_ELEMENTS = """\
elements:
  - id: data
    title: Data quality
    items:
      - id: survey
        title: Field survey
        contents:
          - {id: field_check, title: Field check}
          - {id: field_photos, title: Field photos, title_zh: 外业照片}
  - id: extra
    title: Extra quality
    items:
      - id: extra_item
        title: Extra item
        title_zh: 附加项
        contents:
          - {id: extra_content, title: Extra content, title_zh: 附加内容}
acceptance:
  weights:
    elements: {extra: 0}
    items: {survey: 0, extra_item: 1}
"""


def test_elements_items_and_contents_without_a_chinese_title_are_named(tmp_path) -> None:
    """An item, a content and an element a project pack adds in English alone were shown so on
    the Chinese pages (the contents table, the acceptance page's contents and scores) and no
    warning said it. Named as the rules are, with their lines (pack 1, extends 2, elements 3,
    data 4, survey 7, field_check 10, extra 12); the data element the stock pack titles in
    Chinese keeps its 数据质量, so it is not named."""
    pack = extension_pack(tmp_path, _ELEMENTS)
    assert [str(w) for w in untranslated_titles(load_pack(pack))] == [
        f"{pack}: item survey (line 7), content field_check (line 10), element extra (line 12) "
        "have no title_zh: a Chinese page (--lang zh) shows their English titles; give each a "
        "title_zh"
    ]


def test_rules_and_contents_of_one_file_are_one_warning(tmp_path) -> None:
    body = _RULE.format(rid="PR-1", bound=0.5, zh="")
    one = "\n".join(_ELEMENTS.splitlines()[:9]) + "\n"  # survey and its contents alone
    one += "acceptance:\n  weights:\n    items: {survey: 0}\n"  # lines 12..14, rules 15
    pack = extension_pack(tmp_path, one + "rules:\n" + body)
    assert [str(w) for w in untranslated_titles(load_pack(pack))] == [
        f"{pack}: rule PR-1 (line 16), item survey (line 7), content field_check (line 10) have "
        "no title_zh: a Chinese page (--lang zh) shows their English titles; give each a title_zh"
    ]


def test_a_content_is_named_in_the_file_that_writes_it(tmp_path) -> None:
    parent = extension_pack(tmp_path, _ELEMENTS, "parent")
    child = extension_pack(tmp_path, "rules: []\n", "child", "parent.yaml")
    assert [str(w) for w in untranslated_titles(load_pack(child))] == [
        f"{parent}: item survey (line 7), content field_check (line 10), element extra (line 12) "
        "have no title_zh: a Chinese page (--lang zh) shows their English titles; give each a "
        "title_zh"
    ]


def test_re_rendering_in_chinese_names_the_contents_from_results_json(blockqc, tmp_path) -> None:
    pack = extension_pack(tmp_path, _ELEMENTS)
    block = SAMPLES / "batch" / "F1-B01"
    run = blockqc("inspect", block, "--rules", pack, "--out", tmp_path / "o", "--no-pdf")
    assert run.returncode == 0, run.stderr
    results = tmp_path / "o" / "F1-B01" / "results.json"
    again = blockqc("report", results, "--out", tmp_path / "zh", "--lang", "zh", "--no-pdf")
    assert again.returncode == 0, again.stderr
    warning = (
        f"warning: {pack}: item survey, content field_check, element extra have no title_zh "
        "(pack project 1): a Chinese page (--lang zh) shows their English titles; give each a "
        "title_zh in the pack"
    )
    assert again.stderr.count(warning) == 1, again.stderr
    page = (tmp_path / "zh" / "F1-B01" / "report.html").read_text("utf-8")
    assert "Field survey" in page  # shown as written, not translated
