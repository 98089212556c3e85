"""matplotlib figures in a page's language: Chinese text drawn with the packaged CJK font."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache, wraps
from typing import Any, TypeVar

from blockqc.report.html import FONT_FILE

T = TypeVar("T")

#: the packaged font's family (blockqc/report/fonts/README.md)
CJK_FAMILY = "Blockqc Sans SC"


@cache
def _register() -> None:
    from matplotlib import font_manager

    font_manager.fontManager.addfont(str(FONT_FILE))


@contextmanager
def figure_language(lang: str) -> Iterator[None]:
    """Figures made (and saved) inside draw Latin text in DejaVu Sans, as in English, and every
    character it lacks (the Chinese) in the packaged CJK font; English figures are left alone."""
    if lang != "zh":
        yield
        return
    import matplotlib

    _register()
    with matplotlib.rc_context({"font.family": ["DejaVu Sans", CJK_FAMILY]}):
        yield


def in_language(plot: Callable[[Any, str], T]) -> Callable[[Any, str], T]:
    """`plot(data, lang)` made and saved inside `figure_language(lang)`."""

    @wraps(plot)
    def speaking(data: Any, lang: str = "en") -> T:
        with figure_language(lang):
            return plot(data, lang)

    return speaking
