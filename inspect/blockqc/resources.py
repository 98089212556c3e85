"""Where the stock rule packs and templates live: in the wheel, or in the checkout."""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_CHECKOUT = _PACKAGE.parents[1]  # inspect/blockqc -> inspect -> checkout


def _data_dir(name: str) -> Path:
    packaged = _PACKAGE / "_data" / name
    if packaged.is_dir():
        return packaged
    return _CHECKOUT / name


def rules_dir() -> Path:
    """The folder of the stock rule packs (`rules/`)."""
    return _data_dir("rules")


def templates_dir() -> Path:
    """The folder of the stock Jinja2 templates (`templates/`)."""
    return _data_dir("templates")
