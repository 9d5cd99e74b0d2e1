"""A real headless browser for the tests that look at pages as a reader does.

:func:`rendered_text` loads a page in Chromium, lets its scripts run (MathJax typesets the maths),
and returns the text a reader sees. :data:`RAW_TEX` is what must not be in it: TeX that no
renderer turned into maths.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

#: Raw TeX left in the visible text: a dollar, \begin, \frac, or the \( \[ delimiters.
RAW_TEX = re.compile(r"\$|\\begin\b|\\frac\b|\\\(|\\\[")
#: Elements whose text is not prose: code, scripts, and what MathJax already rendered.
_NOT_PROSE = {"script", "style", "pre", "code", "textarea", "noscript", "template", "svg", "mjx-container"}
_VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}
_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def chromium() -> str:
    """The browser's executable; skipped where none is installed, a failure in CI (which installs one)."""
    for name in _NAMES:
        found = shutil.which(name)
        if found:
            return found
    message = "no headless Chromium found (Debian: apt-get install chromium; .ci/run installs it)"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


class _VisibleText(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.open: list[str] = []
        self.parts: list[str] = []

    def handle_starttag(self, tag: str, attrs) -> None:
        if tag not in _VOID:
            self.open.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in _VOID or tag not in self.open:
            return
        while self.open.pop() != tag:
            pass

    def handle_data(self, data: str) -> None:
        if not _NOT_PROSE.intersection(self.open):
            self.parts.append(data)


def visible_text(html: str) -> str:
    """The prose of ``html``: its text outside code, scripts and rendered maths."""
    parser = _VisibleText()
    parser.feed(html)
    return " ".join(parser.parts)


def rendered_dom(page: Path, budget_ms: int = 20000) -> str:
    """The DOM of ``page`` after Chromium ran its scripts for up to ``budget_ms`` of virtual time."""
    done = subprocess.run(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
         f"--virtual-time-budget={budget_ms}", "--dump-dom", page.resolve().as_uri()],
        capture_output=True, text=True, timeout=120, check=True)
    return done.stdout


def raw_tex(html: str) -> list[str]:
    """Each place where raw TeX is visible in ``html`` (with 30 characters either side)."""
    text = visible_text(html)
    return [text[max(0, m.start() - 30):m.end() + 30] for m in RAW_TEX.finditer(text)]
