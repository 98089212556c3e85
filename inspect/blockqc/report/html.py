"""results.json → HTML with Jinja2 (autoescape on, StrictUndefined, user templates first)."""

from __future__ import annotations

import base64
from collections.abc import Sequence
from contextlib import suppress
from functools import cache
from pathlib import Path
from typing import Any, NamedTuple

import jinja2
from jinja2 import nodes
from markupsafe import Markup, escape

from blockqc.errors import InputError, Problem
from blockqc.report.build import block_context
from blockqc.report.format import number
from blockqc.resources import templates_dir
from blockqc.results import BlockResults

FONT_FILE = Path(__file__).resolve().parent / "fonts" / "BlockqcSansSC-Regular.otf"


def _fmt(value: Any, digits: int = 2) -> str:
    """Numbers for people: fixed decimals, missing as an en dash."""
    return number(value, digits if isinstance(value, float) else None)


def _group(group: dict[str, Any]) -> str:
    return ", ".join(f"{v}".replace("_", "-") for v in group.values())


def _css_string(value: Any) -> Markup:
    """Text as a quoted CSS string inside a <style> element: quotes, backslashes, angle brackets
    and control characters written as CSS escapes."""
    text = "".join(
        f"\\{ord(c):x} " if c in "\"\\<>&'" or ord(c) < 32 or ord(c) == 127 else c
        for c in str(value)
    )
    return Markup(f'"{text}"')


def language_context(lang: str) -> dict[str, Any]:
    """What a page's template needs to speak `lang`: `lang`, `html_lang` (its <html lang>),
    `t` (a catalogue label), `th` (a label whose {fields} may be markup such as `code(...)`,
    other values escaped), `code`, `link`, `paren` (' (x)' or '（x）'), `f` (the Formatter),
    `px` (the unit) and punctuation."""
    from blockqc.report.format import Formatter
    from blockqc.report.messages import LANGUAGES, MESSAGES

    f = Formatter(lang)
    index = LANGUAGES.index(lang)

    def th(key: str, **values: Any) -> Markup:
        text = MESSAGES[key][index] if values else f.t(key)
        text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
        return Markup(text).format(**values) if values else Markup(text)  # quotes as written

    def paren(text: Any) -> Markup:
        return Markup(f.paren(escape(text)))  # the text escaped, its brackets as they are

    return {
        "lang": lang,
        "html_lang": "zh-CN" if lang == "zh" else "en",
        "t": f.t,
        "th": th,
        "code": lambda text: Markup("<code>{}</code>").format(text),
        "link": lambda name: Markup('<a href="{0}">{0}</a>').format(name),
        "paren": paren,
        "f": f,
        "px": f.unit("px"),
        # between sentences on separate lines of a template ({{ sep }} then {{- or {%-): a line
        # break in English, none between Chinese sentences
        "sep": "" if lang == "zh" else "\n",
        "comma": "，" if lang == "zh" else ", ",
        "colon": f.colon,
        "semicolon": "；" if lang == "zh" else ";",
        "stop": "。" if lang == "zh" else ".",
    }


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
        bytecode_cache=_bytecode_cache(),
    )
    env.filters["fmt"] = _fmt
    env.filters["group"] = _group
    env.filters["css_string"] = _css_string
    return env


class _CompiledTemplates(jinja2.FileSystemBytecodeCache):
    """Templates compiled once for every later process (Jinja's cache in a folder of this user's
    own under the system's temporary folder, each entry checked against its template's source):
    compiling the block page costs more than rendering it. A cache that cannot be read or
    written is passed over: the template is then compiled as without one."""

    def load_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        try:
            super().load_bytecode(bucket)
        except Exception:  # a damaged entry: the template is compiled again, the entry rewritten
            bucket.reset()

    def dump_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        with suppress(OSError):
            super().dump_bytecode(bucket)


@cache
def _bytecode_cache() -> jinja2.BytecodeCache | None:
    """The compiled templates' cache of this process, None where no safe folder can be had."""
    try:
        return _CompiledTemplates()
    except (OSError, RuntimeError):
        return None


#: the pages of the block and batch reports
PAGES = ("block.html.j2", "summary.html.j2", "acceptance.html.j2")


def check_templates(
    folder: Path, env: jinja2.Environment, pages: Sequence[str] = PAGES
) -> set[str]:
    """The pages, and every template they include, import or extend, compiled once in `env`
    (the user's `folder` first): one that cannot be read is refused with its file and line before
    anything is inspected or written (not taken, block after block, for a delivery that could
    not be inspected). Templates of other pages in the folder are left alone. The names of the
    templates the pages use."""
    todo: list[_Reference] = [_Reference([name]) for name in pages]
    seen: set[str] = set()
    while todo:
        ref = todo.pop()
        for name in ref.names:  # the first there is taken
            try:
                source, file, _ = env.loader.get_source(env, name)  # type: ignore[union-attr]
            except jinja2.TemplateNotFound:
                continue
            except UnicodeDecodeError:
                where = folder / name if (folder / name).is_file() else name
                problem = Problem(str(where), "not a template: expected UTF-8 text")
                raise InputError(problem) from None
            break
        else:
            if ref.optional:  # `ignore missing`: Jinja renders nothing in its place
                continue
            names = " or ".join(ref.names)
            what = f"{names}: no such template, in the folder or the stock ones"
            raise InputError(Problem(ref.by or names, what, line=ref.line))
        if name in seen:
            continue
        seen.add(name)
        try:
            env.compile(source, name, file)
            todo += [r._replace(by=file) for r in _references(env.parse(source))]
        except jinja2.TemplateSyntaxError as exc:  # also a filter or test that does not exist
            problem = f"not a readable template: {exc.message}"
            raise InputError(Problem(exc.filename or name, problem, line=exc.lineno)) from None
    return seen


class _Reference(NamedTuple):
    """A template a template includes, imports or extends: its names (a list names choices,
    the first there taken), whether it may be missing (`ignore missing`), and where it stands."""

    names: list[str]
    optional: bool = False
    by: str | None = None
    line: int | None = None


def _references(tree: nodes.Template) -> list[_Reference]:
    """The templates a parsed template names (as `meta.find_referenced_templates`), each with
    its line; a name computed at render time is left to the render."""
    kinds = (nodes.Extends, nodes.Include, nodes.Import, nodes.FromImport)
    out = []
    for node in tree.find_all(kinds):
        given = node.template
        if isinstance(given, nodes.Const):
            items = given.value if isinstance(given.value, list | tuple) else [given.value]
        elif isinstance(given, nodes.List | nodes.Tuple):  # choices, unless one is computed
            consts = all(isinstance(i, nodes.Const) for i in given.items)
            items = [i.value for i in given.items] if consts else []  # type: ignore[attr-defined]
        else:
            items = []
        names = [n for n in items if isinstance(n, str) and n]
        if names:
            optional = bool(getattr(node, "ignore_missing", False))
            out.append(_Reference(names, optional, line=node.lineno))
    return out


def render_page(
    template: str,
    ctx: dict[str, Any],
    env: jinja2.Environment | None = None,
    *,
    for_pdf: str | None = None,
) -> str:
    """One page from a prepared context; `for_pdf`, the PDF engine the page is for, adds the
    packaged CJK font, opens every folded list (`printing`), and for WeasyPrint makes each
    figure an SVG image (in Chromium an SVG image cannot use the page's fonts, so there the
    figures stay inline, as on screen)."""
    env = env or environment()
    speech = language_context(ctx.get("lang", "en"))  # its punctuation, unless ctx has its own
    return env.get_template(template).render(
        **{**speech, **ctx},
        printing=bool(for_pdf),
        font_url=FONT_FILE.as_uri() if for_pdf else "",
        figure=_figure_as_image if for_pdf == "weasyprint" else _figure_inline,
    )


def _figure_inline(svg: str) -> Markup:
    """A figure made by blockqc.report.plots (never from input text), inline in the page."""
    return Markup(svg)


def _figure_as_image(svg: str) -> Markup:
    """The same figure for print, as an SVG image: WeasyPrint lays it out as one replaced box."""
    data = base64.b64encode(svg.encode("utf-8")).decode("ascii")
    return Markup(f'<img class="figure" alt="" src="data:image/svg+xml;base64,{data}">')


def render_block(
    results: BlockResults,
    env: jinja2.Environment | None = None,
    *,
    lang: str = "en",
    for_pdf: str | None = None,
) -> str:
    """The block report's HTML."""
    return render_page("block.html.j2", block_context(results, lang), env, for_pdf=for_pdf)


__all__: Sequence[str] = ["environment", "render_block", "render_page"]
