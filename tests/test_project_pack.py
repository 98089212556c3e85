"""A project adds a rule in one place — its pack file — and the report places and names it."""

from __future__ import annotations

import json

import yaml
from markupsafe import escape

from blockqc.report.build import block_context
from casekit import SAMPLES, run_blockqc

RULE = {
    "id": "TP-6",
    "title": "At most 10 % of each scene's tie points above 1 px",
    "title_zh": "每景影像误差大于 1 像素的连接点不超过 10%",
    "description_zh": "每景全色影像中误差大于 1 像素的连接点观测不超过 10%。",
    "clause": "§TP-3",
    "content": "tp_distribution",
    "metric": "tie_point_errors",
    "params": {"bands": ["pan"], "interval_px": [1.0, 1.0e9]},
    "scope": "scene",
    "statistic": "share_in_interval",
    "threshold": {"max": 10},
    "unit": "%",
}


def write_project(folder):
    folder.mkdir(parents=True, exist_ok=True)
    pack = folder / "my-project.yaml"
    doc = {"pack": "my-project", "version": "1", "extends": "global-project", "rules": [RULE]}
    pack.write_text(yaml.safe_dump(doc, allow_unicode=True), encoding="utf-8")
    return pack


def test_a_project_rule_is_reported_under_its_content_in_both_languages(tmp_path):
    pack = write_project(tmp_path / "pack")
    for lang in ("en", "zh"):
        out = tmp_path / f"out-{lang}"
        proc = run_blockqc(
            "inspect", SAMPLES / "batch" / "F1-B01", "--rules", pack, "--out", out,
            "--lang", lang, "--no-pdf",
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        results = json.loads((out / "F1-B01" / "results.json").read_text(encoding="utf-8"))
        mine = [r for r in results["results"] if r["rule"] == "TP-6"]
        assert [r["status"] for r in mine] == ["pass"] and mine[0]["content"] == ["tp_distribution"]
        ctx = block_context(results, lang)
        placed = {
            c["name"]: [x["rule"] for x in c["results"]]
            for e in ctx["elements"]
            for i in e["items"]
            for c in i["contents"]
        }
        name = "连接点分布" if lang == "zh" else "Distribution of connection points"
        assert placed[name] == ["TP-5", "TP-6"] and ctx["others"] == []
        html = (out / "F1-B01" / "report.html").read_text(encoding="utf-8")
        assert escape(RULE["title_zh"] if lang == "zh" else RULE["title"]) in html
