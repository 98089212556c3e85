"""The warnings of rfm-accuracy and adjust are the catalogue's sentences: results.json keeps their
English, a page shows them in its language (Formatter.sentence). A producer of warnings (a
function named *_warning or *_warnings in blockqc.rfm or blockqc.adjust) writes no English of
its own, so that no warning can be added in English only."""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
import textwrap

import pytest

import blockqc.adjust
import blockqc.rfm
from blockqc.report.format import NESTED, SENTENCES, Formatter
from blockqc.report.messages import MESSAGES

#: the producers known when the catalogue took the warnings in; any other found is checked too
KNOWN = {
    "blockqc.rfm.pipeline.run_warnings",
    "blockqc.rfm.pipeline.height_warning",
    "blockqc.rfm.pipeline.reference_warning",
    "blockqc.rfm.accuracy.k_warnings",
    "blockqc.adjust.run.height_warnings",
    "blockqc.adjust.run.scene_warnings",
    "blockqc.adjust.run.fit_warnings",
    "blockqc.adjust.run.checkpoint_warning",
    "blockqc.adjust.run.prior_warnings",
    "blockqc.adjust.run.held_warnings",
}


def _producers() -> dict[str, object]:
    found = {}
    for package in (blockqc.rfm, blockqc.adjust):
        for info in pkgutil.iter_modules(package.__path__, f"{package.__name__}."):
            module = importlib.import_module(info.name)
            for name, func in inspect.getmembers(module, inspect.isfunction):
                if func.__module__ == info.name and re.search(r"_warnings?$", name):
                    found[f"{info.name}.{name}"] = func
    return found


PRODUCERS = _producers()


def _texts(func: object) -> list[str]:
    """The strings written in `func` (the parts of its f-strings too), but its docstring and
    the names of data (subscripts, dictionary keys)."""
    (node,) = ast.parse(textwrap.dedent(inspect.getsource(func))).body
    body = node.body[1:] if ast.get_docstring(node) else node.body
    nodes = [n for stmt in body for n in ast.walk(stmt)]
    names = {id(n.slice) for n in nodes if isinstance(n, ast.Subscript)}
    names |= {id(k) for n in nodes if isinstance(n, ast.Dict) for k in n.keys}
    return [
        n.value
        for n in nodes
        if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in names
    ]


def test_every_producer_is_found():
    assert set(PRODUCERS) >= KNOWN


@pytest.mark.parametrize("name", sorted(PRODUCERS))
def test_a_producer_writes_its_warnings_from_the_catalogue(name):
    """Its texts are catalogue keys (and names of keys, format specs, separators), never English
    words of their own; every key it names is a sentence the page translates."""
    texts = _texts(PRODUCERS[name])
    english = [s for s in texts if not s.isidentifier() and re.search(r"[A-Za-z]{2,}", s)]
    assert english == [], f"{name} writes English of its own: give it a catalogue key"
    keys = [s for s in texts if s in MESSAGES]
    assert keys, f"{name} names no catalogue key"
    assert [k for k in keys if k not in SENTENCES] == []


def test_nested_sentences_are_sentences():
    keys = {key for key, _ in NESTED} | {k for inner in NESTED.values() for k in inner}
    assert keys - set(SENTENCES) == set()


def test_every_sentence_is_read_as_itself_and_has_its_chinese():
    """Each sentence's English, its {fields} as they are, is read as that sentence (no other
    before it takes it) and shown in Chinese (but those with a NESTED field, which takes only the
    sentences it names)."""
    zh = Formatter("zh")
    outer = {key for key, _ in NESTED}
    for key in SENTENCES:
        en, text = MESSAGES[key]
        assert re.search(r"[\u4e00-\u9fff]", text), key
        assert key in outer or zh.sentence(en) == text, key
