"""Test helpers: the command line in a child process, the samples, and the rule-case base
delivery (which lives in the package, `blockqc.rules.casebase`, so that any pack's cases run)."""

from __future__ import annotations

import html as html_lib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from blockqc.rules.casebase import base_manifest, base_tables, write_delivery
from blockqc.rules.cases import aggregate_status

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "samples"

__all__ = [
    "ROOT",
    "SAMPLES",
    "aggregate_status",
    "base_manifest",
    "base_tables",
    "english_left",
    "page_overflow_px",
    "run_blockqc",
    "write_delivery",
]


#: a project's tie-point rules over the stock pack, for tests of rule cases: PA-1 a count per
#: PAN scene (≥ 100), PA-2 the RMS error over the block (≤ 0.5 px)
PA1_RULE = """\
  - id: PA-1
    title: At least 100 tie points in every PAN scene
    clause: §TP-4
    content: tp_number
    metric: tie_point_distribution
    params: {bands: [pan]}
    scope: scene
    statistic: n_points
    threshold: {min: 100}
    unit: points
"""
#: a project's rules: one rule of its own, PR-1, judging the tie points' RMS error by 0.5 px
PR1_RULES = (
    "rules:\n  - id: PR-1\n    title: Tie-point RMS\n    clause: §TP-1\n"
    "    content: ro_report\n    metric: tie_point_errors\n    statistic: rms\n"
    "    threshold: {max: 0.5}\n    unit: px\n"
)
PA2_RULE = """\
  - id: PA-2
    title: Tie-point RMS error within 0.5 px
    clause: §TP-1
    content: ro_report
    metric: tie_point_errors
    params: {bands: [pan]}
    statistic: rms
    threshold: {max: 0.5}
    unit: px
"""


def run_blockqc(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the real command line in a child process (exit status, stdout, stderr)."""
    return subprocess.run(
        [sys.executable, "-m", "blockqc", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )


def extension_pack(
    tmp_path: Path, body: str, name: str = "project", extends: str = "global-project"
) -> Path:
    """A pack file `<name>.yaml` extending `extends` with `body` (YAML text), in tmp_path."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"pack: {name}\nextends: {extends}\n{body}", "utf-8")
    return path


def project_with_cases(tmp_path: Path, rules: str, cases: dict[str, str]) -> Path:
    """A project pack of `rules` over the stock pack, with a case file per rule id given."""
    pack = extension_pack(tmp_path, rules)
    (tmp_path / "project.cases").mkdir()
    for rule, text in cases.items():
        (tmp_path / "project.cases" / f"{rule}.yaml").write_text(text, "utf-8")
    return pack


def lint_messages(path: Path) -> list[str]:
    """Every problem `blockqc rules lint` finds in a pack file, as printed."""
    from blockqc.rules.lint import lint

    return [str(p) for p in lint(path)[1]]


def english_left(html: str, allowed: set[str]) -> set[str]:
    """The English words a page shows outside its file names, paths and ids (the text of <code>
    and <a> elements, words holding '_', '.' or '/'), its styles, scripts and figures' metadata,
    and `allowed` (units, abbreviations such as RMSE): a Chinese page shows none."""
    text = re.sub(r"<(style|script|code|a|metadata)\b.*?</\1>", " ", html, flags=re.S)
    text = html_lib.unescape(re.sub(r"<[^>]*>", " ", text))
    tokens = re.split(r"[\s，。：；（）、“”]+", text)
    words = {
        w
        for token in tokens
        if not re.search(r"[A-Za-z0-9][._/][A-Za-z0-9]", token)
        for w in re.findall(r"[A-Za-z]{2,}", token)
    }
    return words - allowed


def page_overflow_px(html: str, folder: Path, width: int = 1280) -> int:
    """How far `html`, shown in headless Chromium in a window `width` px wide, runs past the
    window's right edge (0: nothing cut off, no horizontal scrolling); skipped without Chromium
    unless BLOCKQC_REQUIRE_BROWSER is set."""
    exe = shutil.which("chromium")
    if exe is None:
        if os.environ.get("BLOCKQC_REQUIRE_BROWSER"):
            pytest.fail("chromium is required (BLOCKQC_REQUIRE_BROWSER is set)")
        pytest.skip("chromium is not installed")
    probe = (
        "<script>addEventListener('load', () => document.body.setAttribute('data-overflow', "
        "document.documentElement.scrollWidth - innerWidth))</script>"
    )
    page = folder / "overflow-probe.html"
    page.write_text(html.replace("</body>", probe + "</body>"))
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"]
    proc = subprocess.run(
        [exe, *flags, f"--user-data-dir={folder / 'profile'}", f"--window-size={width},900",
         "--dump-dom", page.as_uri()],
        capture_output=True, text=True, timeout=120, check=True,
    )  # fmt: skip
    found = re.search(r'data-overflow="(-?\d+)"', proc.stdout)
    assert found, proc.stdout[-500:]
    return int(found.group(1))
