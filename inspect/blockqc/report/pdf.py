"""HTML → PDF with WeasyPrint (the default) or Chromium, in the packaged CJK font (never a silent
fallback)."""

from __future__ import annotations

import gc
import logging
from pathlib import Path

from blockqc.report.html import FONT_FILE


class FontProblem(RuntimeError):
    """The packaged CJK font could not be used: the PDF would show empty boxes."""


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


#: the PDF engines: WeasyPrint (installed with blockqc) or a Chromium installed on the machine
ENGINES = ("weasyprint", "chromium")


def html_to_pdf(html: str, base_url: Path | None = None, engine: str = "weasyprint") -> bytes:
    """The PDF of an HTML page whose CSS names the packaged font (print CSS: A4, page numbers),
    made for `engine` (`render_page(..., for_pdf=engine)`)."""
    if engine not in ENGINES:
        raise ValueError(f"PDF engine {engine!r}: choose one of {', '.join(ENGINES)}")
    if not FONT_FILE.is_file():
        raise FontProblem(f"the report font {FONT_FILE} is missing: reinstall blockqc")
    if engine == "chromium":
        from blockqc.report import chromium

        return chromium.html_to_pdf(html, base_url)
    from weasyprint import HTML
    from weasyprint.text.fonts import FontConfiguration

    collect = _Collect()
    logger = logging.getLogger("weasyprint")
    logger.addHandler(collect)
    collecting = gc.isenabled()
    gc.disable()  # the layout makes ~10⁶ short-lived objects: no cycle search while it runs
    try:
        fonts = FontConfiguration()
        data = HTML(string=html, base_url=str(base_url) if base_url else None).write_pdf(
            font_config=fonts
        )
    finally:
        logger.removeHandler(collect)
        if collecting:
            gc.enable()
    bad = [m for m in collect.messages if "font" in m.lower() and FONT_FILE.name in m]
    if bad:
        raise FontProblem(f"the report font {FONT_FILE} could not be loaded: {bad[0]}")
    return data


__all__ = ["ENGINES", "FontProblem", "html_to_pdf"]
