"""Compiled templates are kept for later processes (Jinja's bytecode cache): a damaged or
unwritable cache, or a template edited since, never changes a page."""

from __future__ import annotations

import jinja2
import pytest

from blockqc.report import html


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    """The compiled templates' cache in a folder of the test's own."""
    folder = tmp_path / "cache"
    folder.mkdir()
    monkeypatch.setattr(html, "_bytecode_cache", lambda: html._CompiledTemplates(str(folder)))
    return folder


def _page(templates, name="page.html.j2", **ctx) -> str:
    return html.environment(templates).get_template(name).render(**ctx)


def test_a_compiled_template_is_kept_and_used_by_the_next_environment(tmp_path, cache_dir):
    (tmp_path / "page.html.j2").write_text("<p>{{ n | fmt(1) }}</p>", "utf-8")
    assert _page(tmp_path, n=2.25) == "<p>2.2</p>"
    assert len(list(cache_dir.iterdir())) == 1
    assert _page(tmp_path, n=0.75) == "<p>0.8</p>"


def test_a_template_edited_since_it_was_compiled_is_compiled_again(tmp_path, cache_dir):
    page = tmp_path / "page.html.j2"
    page.write_text("first {{ x }}", "utf-8")
    assert _page(tmp_path, x=1) == "first 1"
    page.write_text("second {{ x }}", "utf-8")
    assert _page(tmp_path, x=1) == "second 1"


def test_a_damaged_cache_entry_is_passed_over_and_written_anew(tmp_path, cache_dir):
    (tmp_path / "page.html.j2").write_text("<b>{{ x }}</b>", "utf-8")
    _page(tmp_path, x=1)
    (entry,) = cache_dir.iterdir()
    magic = entry.read_bytes()[: len(jinja2.bccache.bc_magic)]
    for damaged in (b"", b"not a cache entry", magic + b"\x80\x04garbage"):
        entry.write_bytes(damaged)
        assert _page(tmp_path, x=2) == "<b>2</b>"
    assert entry.read_bytes().startswith(magic)


def test_a_cache_that_cannot_be_written_is_passed_over(tmp_path, monkeypatch):
    gone = tmp_path / "gone"
    monkeypatch.setattr(html, "_bytecode_cache", lambda: html._CompiledTemplates(str(gone)))
    (tmp_path / "page.html.j2").write_text("{{ x }}", "utf-8")
    assert _page(tmp_path, x=3) == "3"
    assert not gone.exists()
