"""The course in a real browser: JupyterLab as `make lab` serves it, driven by headless Chromium.

nbclient (tests/test_notebooks.py) runs the notebooks' code but renders nothing; this test opens
JupyterLab in Debian's ``chromium`` (driven by the ``playwright`` Python package, with no browser
download), runs notebooks with Run All and fails on

- an error output in any cell,
- a widget that does not render (ipywidgets' "Error displaying widget", or a widget still loading
  once the notebook has run),
- an ERROR the inline rerun viewer writes to the browser console.

Not yet caught: the error badge rerun draws on a view whose entity misses a component its
visualizer needs (e.g. 08's legs logged as Points2D under a blueprint expecting Ellipses2D). The
viewer draws it inside its canvas and does not write it to the console (checked: Run All of 08 with
that fault logs no such line), so this test does not see it yet.

The server runs with the configuration of `make lab` (``jupyter/`` first on JUPYTER_CONFIG_PATH,
RERUN_NOTEBOOK_ASSET=serve-local, so nothing is fetched from the internet) on copies of the
notebooks in a temporary folder (Run All must not save outputs into the repository). The same
server is checked to show students nbgrader's student side only.

Needs /usr/bin/chromium (`.ci/run` and `make test` install it as root with apt-get) and the
``playwright`` package (dev extra); skips with the reason when either is missing.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = Path(os.environ.get("LABKIT_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
NOTEBOOKS = ["00_tour.ipynb", "08_iav_circles_and_legs.ipynb", "09_bag_playback_in_rerun.ipynb"]
EXERCISE = REPO / "exercises" / "release" / "ex00_polar_to_cartesian" / "ex00_polar_to_cartesian.ipynb"
TOKEN = "labkit-browser-test"
RUN_LIMIT_S = 420  # per notebook, generous: two cores shared with the rest of `make test`
SETTLE_S = 8  # after the last cell, for the widgets and viewers to draw (and report their errors)

pytestmark = pytest.mark.slow

# Console text by which rerun's viewer reports an error (its Rust log level, as it prints it).
RERUN_ERROR_MARKERS = (" ERROR re_", "panicked at")


def _playwright():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("the playwright Python package is missing: install the dev extra (pip install -e '.[dev]')")
    if not CHROMIUM.is_file():
        pytest.skip(f"{CHROMIUM} is missing: 'sudo apt-get install chromium' (make test installs it as root)")
    return sync_playwright


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(url: str, data: bytes | None = None) -> tuple[int, str]:
    request = urllib.request.Request(url, data=data, headers={"Authorization": f"token {TOKEN}"})
    try:
        with urllib.request.urlopen(request, timeout=120) as response:
            return response.status, response.read().decode()
    except urllib.error.HTTPError as error:
        return error.code, error.read().decode(errors="replace")


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A JupyterLab server with `make lab`'s configuration on copies of the notebooks; its base URL."""
    _playwright()
    root = tmp_path_factory.mktemp("lab")
    for name in NOTEBOOKS:
        shutil.copy(REPO / "notebooks" / name, root / name)
    shutil.copy(EXERCISE, root / EXERCISE.name)
    kernels = root / ".jupyter-data" / "kernels" / "python3"
    kernels.mkdir(parents=True)
    (kernels / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (labkit)", "language": "python"}))
    env = dict(os.environ,
               JUPYTER_CONFIG_PATH=str(REPO / "jupyter"),  # as `make lab`
               RERUN_NOTEBOOK_ASSET="serve-local",  # as `make lab`: the viewer's code from the installed package
               JUPYTER_PATH=str(root / ".jupyter-data"),
               JUPYTERLAB_WORKSPACES_DIR=str(root / ".workspaces"),
               JUPYTER_RUNTIME_DIR=str(root / ".runtime"),
               PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    port = _free_port()
    log = (root / "server.log").open("w")
    server = subprocess.Popen(
        [sys.executable, "-m", "jupyter", "lab", "--no-browser", f"--port={port}", "--ServerApp.ip=127.0.0.1",
         f"--IdentityProvider.token={TOKEN}", f"--ServerApp.root_dir={root}", "--LabApp.expose_app_in_browser=True",
         "--ServerApp.allow_root=True"],
        cwd=root, env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                if _get(f"{base}/api/status")[0] == 200:
                    break
            except OSError:
                pass
            if server.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"JupyterLab did not start:\n{(root / 'server.log').read_text()[-3000:]}")
            time.sleep(0.5)
        yield base, root
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()


# ---------------------------------------------------------------------------- the students' nbgrader
def _page_config(base: str) -> dict:
    status, html = _get(f"{base}/lab?token={TOKEN}")
    assert status == 200, f"/lab answered {status}"
    start = html.index('id="jupyter-config-data"')
    start = html.index(">", start) + 1
    return json.loads(html[start:html.index("</script>", start)])


def test_lab_shows_students_the_student_side_of_nbgrader(lab):
    base, _ = lab
    config = _page_config(base)
    disabled = set(config.get("disabledExtensions", []))
    for plugin in ("formgrader", "create-assignment", "menu", "course-list"):
        assert f"@jupyter/nbgrader:{plugin}" in disabled, f"the instructor's {plugin} is on in make lab"
    assert "@jupyter/nbgrader:validate-assignment" not in disabled, "students need Validate"
    assert _get(f"{base}/formgrader")[0] == 404, "the formgrader server extension must be off in make lab"


def test_validate_refuses_a_lesson_and_checks_an_exercise(lab):
    base, _ = lab
    status, body = _get(f"{base}/assignments/validate", data=b"path=00_tour.ipynb")
    answer = json.loads(body)
    assert status == 200 and answer["success"] is False, f"Validate on a lesson: {answer}"
    assert "lesson notebook, not an exercise" in answer["value"]
    status, body = _get(f"{base}/assignments/validate", data=f"path={EXERCISE.name}".encode())
    answer = json.loads(body)
    assert status == 200 and answer["success"] is True, f"Validate on an exercise: {answer}"
    assert answer["value"].get("failed"), f"the unchanged release must fail its visible tests: {answer}"


# ---------------------------------------------------------------------------- Run All in the browser
_MODEL = "() => window.jupyterapp.shell.currentWidget.context.model.toJSON()"
_BUSY = """() => {
  const w = window.jupyterapp.shell.currentWidget;
  const kernel = w && w.sessionContext && w.sessionContext.session && w.sessionContext.session.kernel;
  const prompts = [...document.querySelectorAll('.jp-Notebook .jp-Cell.jp-CodeCell .jp-InputPrompt')];
  return !kernel || kernel.status !== 'idle' || prompts.some(p => p.textContent.includes('*'));
}"""
_UNRENDERED = """() => [...document.querySelectorAll('.jp-OutputArea-output')]
  .map(o => o.innerText || '')
  .filter(t => /Error displaying widget|Loading widget|model not found/i.test(t))"""


def _run_all(page, base: str, name: str) -> tuple[dict, list[str]]:
    """Open ``name``, Run All, wait for the kernel; return the notebook (with outputs) and problems seen."""
    page.goto(f"{base}/lab/tree/{name}?token={TOKEN}&reset")
    page.wait_for_function("() => window.jupyterapp && window.jupyterapp.shell.currentWidget"
                           " && window.jupyterapp.shell.currentWidget.sessionContext"
                           " && window.jupyterapp.shell.currentWidget.sessionContext.session"
                           " && window.jupyterapp.shell.currentWidget.sessionContext.session.kernel"
                           " && window.jupyterapp.shell.currentWidget.sessionContext.session.kernel.status === 'idle'",
                           timeout=180_000)
    page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
    time.sleep(3)
    deadline = time.monotonic() + RUN_LIMIT_S
    while page.evaluate(_BUSY):
        assert time.monotonic() < deadline, f"{name}: Run All did not finish in {RUN_LIMIT_S} s"
        time.sleep(2)
    time.sleep(SETTLE_S)
    return page.evaluate(_MODEL), page.evaluate(_UNRENDERED)


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_run_all_in_the_browser(lab, name, tmp_path):
    base, _ = lab
    sync_playwright = _playwright()
    console: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            context = browser.new_context(viewport={"width": 1400, "height": 1000})
            page = context.new_page()
            page.on("console", lambda message: console.append(f"{message.type}: {message.text}"))
            page.on("pageerror", lambda error: console.append(f"pageerror: {error}"))
            notebook, unrendered = _run_all(page, base, name)
            page.screenshot(path=str(tmp_path / f"{name}.png"), full_page=True)
        finally:
            browser.close()
    (tmp_path / "console.log").write_text("\n".join(console))

    not_run = [k for k, cell in enumerate(notebook["cells"])
               if cell["cell_type"] == "code" and cell["source"].strip() and cell.get("execution_count") is None]
    assert not not_run, f"{name}: cells not run by Run All: {not_run}"
    errors = [f"cell {k}: {o.get('ename')}: {o.get('evalue')}"
              for k, cell in enumerate(notebook["cells"]) if cell["cell_type"] == "code"
              for o in cell.get("outputs", []) if o["output_type"] == "error"]
    assert not errors, f"{name}: error outputs after Run All: {errors}"
    assert not unrendered, f"{name}: widgets that did not render: {unrendered}"
    viewer_errors = [line for line in console if any(m in line for m in RERUN_ERROR_MARKERS)]
    assert not viewer_errors, f"{name}: the rerun viewer reports errors: {viewer_errors}"
