"""The documentation is built, with warnings as errors, and its pages open whole in a browser.

The build is `make docs`'s (``sphinx -b html -W --keep-going``): a broken cross-reference, a docstring
Sphinx cannot read, a missing page or image fails it. The notebooks' outputs come from the copies the
notebook tests kept (docs/executed_notebooks.py), so `make test` runs this file after the rest of the
suite (a run of this file alone executes the notebooks that have no copy yet, once).

Then headless Chromium (Debian's ``chromium`` through the ``playwright`` package, as tests/test_browser.py)
opens the front page, an API page and a notebook page, served over HTTP from the built site, and fails on
a link to a page or file of the site that is missing, an ``#anchor`` a link names that is not on its page,
an image that does not load, or a request of the site's own that fails. The notebook page must show a
figure and the text output of a cell; the API page its signature and parameters; math is typeset
(KaTeX or MathJax markup present where the docstring has math).

Set LABKIT_DOCS_SCREENSHOTS to a folder to keep a screenshot of each page there.
"""

from __future__ import annotations

import fcntl
import functools
import http.server
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import urldefrag, urljoin, urlparse

import pytest

REPO = Path(__file__).resolve().parents[1]
HTML = REPO / "docs" / "_build" / "html"
CHROMIUM = Path(os.environ.get("LABKIT_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
# make docs's build: a fresh environment (-E: no page left from an older docstring), warnings as errors
SPHINX_OPTIONS = ["-b", "html", "-E", "-W", "--keep-going", "-q", "-j", "2"]
PAGES = {
    "index": "index.html",
    "api": "_generated/api/generated/labkit.segmentation.breakpoint_thresholds.html",
    "notebook": "_generated/course/01_scans_and_segmentation.html",
}

pytestmark = [pytest.mark.slow]


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> Path:
    """Build the site once per run (under a lock shared by xdist's workers) and return its folder."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    with (shared / "docs_build.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = shared / "docs_build.done"
        if not done.exists():
            started = time.monotonic()
            run = subprocess.run([sys.executable, "-m", "sphinx", *SPHINX_OPTIONS, "docs", str(HTML)], cwd=REPO,
                                 capture_output=True, text=True)
            assert run.returncode == 0, (f"the docs build failed (make docs):\n{run.stdout[-4000:]}\n"
                                         f"{run.stderr[-8000:]}")
            done.write_text(f"{time.monotonic() - started:.1f}")
    return HTML


def test_build_writes_every_page(site):
    """Every family of the API reference, every course notebook and every released exercise has a page."""
    from docs import public_api

    for slug, _title, _prefixes in public_api.FAMILIES:
        assert (site / "_generated" / "api" / f"{slug}.html").is_file(), slug
    for notebook in (REPO / "notebooks").glob("*.ipynb"):
        assert (site / "_generated" / "course" / f"{notebook.stem}.html").is_file(), notebook.name
    for notebook in (REPO / "exercises" / "release").glob("*/*.ipynb"):
        page = (site / "_generated" / "exercises" / f"{notebook.stem}.html").read_text(encoding="utf-8")
        assert "BEGIN SOLUTION" not in page and "BEGIN HIDDEN TESTS" not in page, notebook.name
    assert (site / "_generated" / "benchmarks.html").is_file()


@pytest.fixture(scope="module")
def server(site):
    handler = functools.partial(_QuietHandler, directory=str(site))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/"
    httpd.shutdown()
    httpd.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002 (the base class's name)
        pass


def _playwright():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("the playwright Python package is missing: install the dev extra (pip install -e '.[dev]')")
    if not CHROMIUM.is_file():
        pytest.skip(f"{CHROMIUM} is missing: 'sudo apt-get install chromium' (make test installs it as root)")
    return sync_playwright


LINKS_JS = """() => ({
  links: [...document.querySelectorAll('a[href]')].map(a => a.href),
  images: [...document.querySelectorAll('img')].map(
    i => ({src: i.currentSrc || i.src, ok: i.complete && i.naturalWidth > 0})),
  ids: [...document.querySelectorAll('[id]')].map(e => e.id),
})"""


def _check_page(page, context, base: str, url: str) -> tuple[list[str], dict]:
    """Problems of one page: links of the site that do not resolve, anchors not on their page, images."""
    failed: list[str] = []
    page.on("requestfailed", lambda r: failed.append(f"request failed: {r.url}") if r.url.startswith(base) else None)
    page.on("response", lambda r: failed.append(f"{r.status}: {r.url}") if r.url.startswith(base) and r.status >= 400
            else None)
    page.goto(url, wait_until="networkidle")
    found = page.evaluate(LINKS_JS)
    problems = list(failed)
    ids_of: dict[str, set[str]] = {urldefrag(url)[0]: set(found["ids"])}
    for href in found["links"]:
        target, fragment = urldefrag(href)
        if not target.startswith(base):
            continue
        if target not in ids_of:
            response = context.request.get(target)
            if response.status >= 400:
                problems.append(f"broken link {href} ({response.status})")
                ids_of[target] = set()
                continue
            ids_of[target] = _ids(response.text()) if urlparse(target).path.endswith(".html") else set()
        if fragment and urlparse(target).path.endswith(".html") and fragment not in ids_of[target]:
            problems.append(f"link to a missing anchor: {href}")
    problems += [f"image not shown: {img['src']}" for img in found["images"] if not img["ok"]]
    return problems, found


def _ids(html: str) -> set[str]:
    import re

    return set(re.findall(r'\sid="([^"]+)"', html))


def test_pages_open_whole_in_a_browser(server, tmp_path):
    sync_playwright = _playwright()
    shots = Path(os.environ.get("LABKIT_DOCS_SCREENSHOTS") or tmp_path)
    shots.mkdir(parents=True, exist_ok=True)
    report: dict[str, list[str]] = {}
    texts: dict[str, str] = {}
    images: dict[str, int] = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            context = browser.new_context(viewport={"width": 1280, "height": 900})
            for name, path in PAGES.items():
                page = context.new_page()
                problems, found = _check_page(page, context, server, urljoin(server, path))
                if name == "api":  # the docstring's math, typeset by the MathJax served with the site
                    try:
                        page.wait_for_selector("mjx-container", timeout=20_000)
                    except Exception:  # playwright's TimeoutError
                        problems.append("the math of the docstring is not typeset (no mjx-container)")
                report[name] = problems
                texts[name] = page.inner_text("main")
                images[name] = sum(img["ok"] for img in found["images"])
                page.screenshot(path=str(shots / f"docs_{name}.png"))
                page.close()
        finally:
            browser.close()
    assert not any(report.values()), "\n".join(f"{name}: {p}" for name, ps in report.items() for p in ps)
    assert images["index"] >= 1, "the front page shows its picture"
    assert images["notebook"] >= 3, f"the notebook page shows its figures ({images['notebook']} images)"
    assert "runs between the cuts" in texts["notebook"], "a cell's printed output is on the page"
    assert "interactive widget" in texts["notebook"], "a widget shows as a note, not as its Python repr"
    assert "Parameters" in texts["api"] and "Returns" in texts["api"]
    assert "breakpoint_thresholds(" in texts["api"]
    # the words of parameter types are plain text: an inventory link the offline build cannot resolve would
    # show its target ("python:float", "numpy:array_like")
    assert not re.search(r"\b(?:python|numpy):\w", texts["api"]), texts["api"]
