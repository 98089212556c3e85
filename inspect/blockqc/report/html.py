"""results.json → HTML with Jinja2 (autoescape on, StrictUndefined, user templates first)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jinja2

from blockqc.resources import templates_dir


def _fmt(value: Any, digits: int = 2) -> str:
    """Numbers for people: fixed decimals, booleans as yes/no, missing as an en dash."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    if isinstance(value, list):
        return ", ".join(_fmt(v, digits) for v in value)
    return str(value)


def _group(group: dict[str, Any]) -> str:
    return ", ".join(f"{v}".replace("_", "-") for v in group.values())


def environment(user_templates: Path | None = None) -> jinja2.Environment:
    """Templates from `user_templates` take precedence over the stock ones."""
    loaders: list[jinja2.BaseLoader] = []
    if user_templates is not None:
        loaders.append(jinja2.FileSystemLoader(str(user_templates)))
    loaders.append(jinja2.FileSystemLoader(str(templates_dir())))
    env = jinja2.Environment(
        loader=jinja2.ChoiceLoader(loaders),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["fmt"] = _fmt
    env.filters["group"] = _group
    return env


def render_block(results: dict[str, Any], env: jinja2.Environment | None = None) -> str:
    env = env or environment()
    return env.get_template("block.html.j2").render(r=results)


def render_summary(summary: dict[str, Any], env: jinja2.Environment | None = None) -> str:
    env = env or environment()
    return env.get_template("summary.html.j2").render(s=summary)


__all__: Sequence[str] = ["environment", "render_block", "render_summary"]
