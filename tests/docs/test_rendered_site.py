"""The documentation site as a reader sees it: built pages opened in a real headless browser.

The maths of the Markdown pages (pymdownx.arithmatex) and of the notebook pages (Jupyter's $ and
$$) must be typeset by the bundled MathJax, with no raw TeX left in the visible text, and no page
may load a script from outside the site (it must render offline).

``make test`` builds the site once and points ``SVRQP_BUILT_SITE`` at it; run alone, the test
builds it into a temporary folder.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from support.browser import raw_tex, rendered_dom
from support.paths import REPO

NOTEBOOK_PAGES = sorted(f"notebooks/{path.stem}/index.html" for path in (REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))
MARKDOWN_PAGES = ["solvers/index.html", "formulations/epsilon-svr/index.html", "formulations/ls-svr/index.html"]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    built = os.environ.get("SVRQP_BUILT_SITE")
    if built and (Path(built) / "index.html").exists():
        return Path(built)
    folder = tmp_path_factory.mktemp("site")
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(folder)],
                   cwd=REPO, check=True, capture_output=True, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    return folder


def test_every_notebook_has_a_page():
    assert len(NOTEBOOK_PAGES) >= 8


@pytest.mark.parametrize("page", NOTEBOOK_PAGES + MARKDOWN_PAGES)
def test_maths_is_typeset_and_no_raw_tex_is_visible(site, page):
    served = (site / page).read_text(encoding="utf-8")
    dom = rendered_dom(site / page)
    assert raw_tex(dom) == []
    if raw_tex(served):  # the page has maths: the check above saw it typeset, not lost
        assert "<mjx-container" in dom, f"{page}: MathJax typeset nothing"


def test_the_check_sees_raw_tex_before_mathjax_runs(site):
    """The same check on pages as served, before any script ran, finds their TeX."""
    for page in (NOTEBOOK_PAGES[0], MARKDOWN_PAGES[0]):
        assert raw_tex((site / page).read_text(encoding="utf-8")), page


@pytest.mark.parametrize("page", ["index.html", NOTEBOOK_PAGES[0], MARKDOWN_PAGES[0]])
def test_pages_load_no_script_from_outside_the_site(site, page):
    html = (site / page).read_text(encoding="utf-8")
    sources = re.findall(r'<script[^>]*\ssrc="([^"]*)"', html)
    assert sources and not [source for source in sources if re.match(r"(https?:)?//", source)]
    assert not [source for source in sources if source == ""], "an empty script source (MathJax 2 leftover)"
