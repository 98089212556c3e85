"""HTML → PDF by a headless Chromium that stays open for the process (`--pdf-engine chromium`).

Chromium is driven over its DevTools protocol on a pipe (JSON messages ended by NUL, on file
descriptors 3 and 4 of the browser). Each page is written to a private folder and loaded from
there, so that the packaged font is read from its file; the PDF is printed once the page and its
fonts have loaded. The browser is started on the first PDF and closed when the process ends, or
when the pipe is closed (a worker process that exits without clean-up).
"""

from __future__ import annotations

import atexit
import base64
import json
import os
import re
import select
import shutil
import subprocess
import tempfile
import time
from multiprocessing import util
from pathlib import Path
from typing import Any

from markupsafe import escape

#: the programs looked for, in order, when BLOCKQC_CHROMIUM does not name one
PROGRAMS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
#: set to 1: PDFs tagged for accessibility (untagged by default, like WeasyPrint's: the
#: structure tree doubles the file and costs a quarter more of Chromium's CPU)
TAGGED = "BLOCKQC_PDF_TAGGED"
#: seconds one page may take from loading to its PDF
TIMEOUT_S = 180.0
FLAGS = (
    "--headless",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--disable-extensions",
    "--disable-background-networking",
    "--allow-file-access-from-files",
    "--no-first-run",
    "--no-default-browser-check",
    "--hide-scrollbars",
    "--mute-audio",
    "--remote-debugging-pipe",
)


class ChromiumProblem(RuntimeError):
    """No Chromium to print with, or it failed or stopped answering."""


def find_chromium() -> str:
    """The Chromium program: BLOCKQC_CHROMIUM, or the first of PROGRAMS on the PATH."""
    given = os.environ.get("BLOCKQC_CHROMIUM")
    if given:
        found = shutil.which(given)
        if not found:
            raise ChromiumProblem(f"BLOCKQC_CHROMIUM={given}: no such program")
        return found
    for name in PROGRAMS:
        found = shutil.which(name)
        if found:
            return found
    raise ChromiumProblem(
        "--pdf-engine chromium: no Chromium found on the PATH (looked for "
        f"{', '.join(PROGRAMS)}); install one (Debian: apt-get install chromium) or name it "
        "in BLOCKQC_CHROMIUM"
    )


class Browser:
    """One headless Chromium and one page, spoken to over the DevTools pipe."""

    def __init__(self, program: str) -> None:
        self.owner = os.getpid()
        self.folder = Path(tempfile.mkdtemp(prefix="blockqc-chromium-"))
        to_browser, self._write = os.pipe()
        self._read, from_browser = os.pipe()
        args = [*FLAGS, f"--user-data-dir={self.folder / 'profile'}", "about:blank"]
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            args.insert(0, "--no-sandbox")  # Chromium's sandbox refuses to run as root
        try:
            self.process = subprocess.Popen(
                [program, *args],
                preexec_fn=_pipe_on_3_and_4(to_browser, from_browser),
                close_fds=False,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        except OSError as exc:
            shutil.rmtree(self.folder, ignore_errors=True)
            raise ChromiumProblem(f"{program} could not be started: {exc}") from None
        finally:
            os.close(to_browser)
            os.close(from_browser)
        self.closed = False
        self._buffer = b""
        self._events: list[dict] = []
        self._id = 0
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        attached = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})
        self.session = attached["sessionId"]
        self.call("Page.enable", session=True)

    def call(self, method: str, params: dict | None = None, *, session: bool = False) -> dict:
        """Send one command and wait for its answer; events that arrive meanwhile are kept."""
        self._id += 1
        message: dict[str, Any] = {"id": self._id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = self.session
        data = json.dumps(message).encode() + b"\0"
        try:
            while data:
                data = data[os.write(self._write, data) :]
        except OSError as exc:
            self.close()
            raise ChromiumProblem(f"Chromium stopped answering ({method}): {exc}") from None
        ident = self._id
        answer = self._next(lambda m: m.get("id") == ident, method)
        if "error" in answer:
            raise ChromiumProblem(f"Chromium could not {method}: {answer['error']}")
        return answer.get("result", {})

    def event(self, method: str) -> dict:
        """Wait for an event of this page."""
        return self._next(
            lambda m: m.get("method") == method and m.get("sessionId") == self.session, method
        )

    def _next(self, wanted, what: str) -> dict:
        for i, kept in enumerate(self._events):
            if wanted(kept):
                return self._events.pop(i)
        deadline = time.monotonic() + TIMEOUT_S
        while True:
            while b"\0" in self._buffer:
                raw, self._buffer = self._buffer.split(b"\0", 1)
                message = json.loads(raw)
                if wanted(message):
                    return message
                if "method" in message:
                    self._events.append(message)
            left = deadline - time.monotonic()
            ready = select.select([self._read], [], [], max(left, 0))[0] if left > 0 else []
            chunk = os.read(self._read, 1 << 20) if ready else b""
            if not chunk:
                why = "closed" if ready else f"no answer in {TIMEOUT_S:.0f} s"
                self.close()
                raise ChromiumProblem(f"Chromium stopped answering ({what}): {why}")
            self._buffer += chunk

    def pdf(self, html: str, base_url: Path | None = None) -> bytes:
        """The PDF of one page (A4 and margins from its print CSS); its relative links lead
        from `base_url`, the folder the PDF is written to."""
        if base_url is not None:
            base = f'<base href="{escape(Path(base_url).resolve().as_uri())}/">'
            html = re.sub(r"<head\b[^>]*>", lambda m: m.group(0) + base, html, count=1)
        page = self.folder / "page.html"
        page.write_text(html, encoding="utf-8")
        self._events.clear()
        self.call("Page.navigate", {"url": page.as_uri()}, session=True)
        self.event("Page.loadEventFired")
        faces = self.call(
            "Runtime.evaluate",
            {
                "expression": "document.fonts.ready.then(() => "
                "[...document.fonts].map(f => [f.family.replace(/\"/g, ''), f.status]))",
                "awaitPromise": True,
                "returnByValue": True,
            },
            session=True,
        )["result"].get("value", [])
        failed = [family for family, status in faces if status == "error"]
        if failed:
            from blockqc.report.pdf import FontProblem

            raise FontProblem(f"Chromium could not load the report font {failed[0]}")
        printed = self.call(
            "Page.printToPDF",
            {
                "printBackground": True,
                "preferCSSPageSize": True,
                "generateDocumentOutline": True,
                "generateTaggedPDF": os.environ.get(TAGGED) == "1",
            },
            session=True,
        )
        return base64.b64decode(printed["data"])

    def close(self) -> None:
        if self.owner != os.getpid() or self.closed:
            return
        self.closed = True
        for fd in (self._write, self._read):
            try:
                os.close(fd)  # the closed pipe ends the browser
            except OSError:
                pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        shutil.rmtree(self.folder, ignore_errors=True)


def _pipe_on_3_and_4(reading: int, writing: int):
    """In the browser's process, before it starts: the pipe's ends as descriptors 3 and 4 (by
    way of high numbers, so that neither end is closed by moving the other)."""

    def move() -> None:
        os.dup2(reading, 1000)
        os.dup2(writing, 1001)
        os.dup2(1000, 3)
        os.dup2(1001, 4)
        os.close(1000)
        os.close(1001)

    return move


_browser: Browser | None = None


def html_to_pdf(html: str, base_url: Path | None = None) -> bytes:
    """The PDF of a page, by this process's Chromium: started on first use, and started again,
    once, when the one running has stopped answering."""
    browser, fresh = _running()
    try:
        return browser.pdf(html, base_url)
    except ChromiumProblem:
        if fresh:
            raise
    return _running()[0].pdf(html, base_url)


def _running() -> tuple[Browser, bool]:
    """This process's browser, and whether it was started now."""
    global _browser
    if _browser is not None and _browser.owner == os.getpid() and not _browser.closed:
        return _browser, False
    _browser = Browser(find_chromium())
    atexit.register(_browser.close)
    util.Finalize(_browser, _browser.close, exitpriority=10)  # in worker processes too
    return _browser, True


__all__ = ["ChromiumProblem", "find_chromium", "html_to_pdf"]
