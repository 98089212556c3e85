"""The HTML page of an RFM accuracy run, rendered from its results.json only."""

from __future__ import annotations

from pathlib import Path

from blockqc.report.format import number, number_beside
from blockqc.report.html import environment, language_context


def _fmt(value: object, digits: int = 3) -> str:
    return number(value, digits if isinstance(value, float) else None)


def render_html(results: dict, template_dir: Path | None = None, lang: str = "en") -> str:
    """HTML for one run in `lang` (en, zh); `template_dir` may hold a user's
    `rfm_accuracy.html.j2` that overrides."""
    template = environment(template_dir).get_template("rfm_accuracy.html.j2")
    acc = results["accuracy"]
    return template.render(
        r=results,
        a=acc,
        d=results["distortion"],
        rmse_shown=number_beside(acc["rmse_px"], acc["requirement_px"]),
        image_name=Path(str(results["image"])).name,
        fmt=_fmt,
        **language_context(lang),
    )
