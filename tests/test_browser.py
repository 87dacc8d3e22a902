"""The course in a real browser: the students' JupyterLab (`labkit lab`, `make lab`), driven by headless Chromium.

nbclient (tests/test_notebooks.py) runs the notebooks' your-turn trials but renders nothing; this test opens
JupyterLab in Debian's ``chromium`` (driven by the ``playwright`` Python package, with no browser download) and
runs EVERY notebook of ``notebooks/`` (a glob: a new one is included) with Run All twice in a row, as a student
who runs it again, in the same kernel. It fails on

- a cell that Run All did not run, an error output in any cell, on either Run All,
- a widget that does not render (ipywidgets' "Error displaying widget", or a widget still loading
  once the notebook has run),
- an ERROR the inline rerun viewer writes to the browser console (either Run All),
- after the first Run All of a notebook with inline rerun viewers: an error badge on a view of a viewer (e.g.
  main's notebook 08: its legs logged as Points2D under a blueprint expecting Ellipses2D, "Component
  'Ellipses2D:half_sizes' does not exist on the entity"), a viewer that never starts or never gets a recording.

The badge is drawn inside the viewer's canvas (wasm/egui), not in the DOM nor on the console, so the
test asks each viewer through rerun's Web Viewer API: ``WebViewer.get_state()`` (rerun 0.41) lists
every view of the blueprint with the warnings and errors it reports. The notebook widget keeps its
WebViewer private, so the test serves the pages a copy of rerun's ``widget.js`` that also keeps each
viewer on ``window`` (one line after ``new ViewerWidget``; if rerun changes that line the viewers
fail to load and every viewer test fails, never passes silently). Once a viewer has its data (the
kernel sent it nothing for QUIET_S and it answers the same twice), it is paused at the start, middle
and end of its timeline, as a student scrubbing it, and its reports read at each. Those waits are paid
only by the notebooks that show inline viewers, and only after their first Run All.
``test_viewer_reports_are_caught`` keeps the detector honest: a probe notebook logs the legs as
main's 08 did (statically and over time, as columns), which must fail, and the same scene logged as
ellipses, which must not.

Under pytest-xdist each worker has its own server and one browser (module-scoped) with the lab loaded once:
each notebook is opened in it, run twice, then closed with its kernel shut down (``SharedLab``), so the
notebooks spread over both workers. The probe of the viewer reports and the exercise path have browsers of
their own.

The server is started with `labkit lab`'s own command and environment (:func:`labkit.grading.lab.lab_command`,
:func:`~labkit.grading.lab.lab_environment`: the instructor tools hidden, Validate = ``labkit grade --check``,
RERUN_NOTEBOOK_ASSET=serve-local, so nothing is fetched from the internet) on copies of the notebooks in a
temporary folder (Run All must not save outputs into the repository). The same server is checked to show students
nbgrader's student side only, and the exercise path is walked in the browser: an exercise opened, filled with a
wrong answer, an answer that calls labkit, a right one (and one whose error message is markup), each Validated.

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
from dataclasses import dataclass, field
from pathlib import Path

import nbformat
import pytest

from docs.executed_notebooks import keep as keep_for_docs
from tests.conftest import SHARED_DATASETS

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = Path(os.environ.get("LABKIT_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
NOTEBOOKS = sorted(p.name for p in (REPO / "notebooks").glob("*.ipynb"))
EX1 = "ex01_range_segmentation"
TOKEN = "labkit-browser-test"
START_LIMIT_S = 300  # for the server to answer: seconds alone, minutes on two cores shared with the rest of make test

pytestmark = [pytest.mark.slow]


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
    """The students' JupyterLab, started with `labkit lab`'s command and environment, on copies of the notebooks
    and of exercise 1; its base URL and folder. One per xdist worker."""
    _playwright()
    from labkit.grading.lab import lab_command, lab_environment

    root = tmp_path_factory.mktemp("lab")
    for name in NOTEBOOKS:
        shutil.copy(REPO / "notebooks" / name, root / name)
    shutil.copy(REPO / "exercises" / "release" / EX1 / f"{EX1}.ipynb", root / f"{EX1}.ipynb")
    kernels = root / ".jupyter-data" / "kernels" / "python3"
    kernels.mkdir(parents=True)
    (kernels / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (labkit)", "language": "python"}))
    env = lab_environment(dict(os.environ,
                               JUPYTER_PATH=str(root / ".jupyter-data"),
                               JUPYTERLAB_WORKSPACES_DIR=str(root / ".workspaces"),
                               JUPYTER_RUNTIME_DIR=str(root / ".runtime")))
    if SHARED_DATASETS.is_dir():  # the notebooks' real-data sections run too (they skip without it)
        env["LABKIT_SHARED_DATASETS"] = str(SHARED_DATASETS.resolve())
    port = _free_port()
    log = (root / "server.log").open("w")
    server = subprocess.Popen(
        lab_command(root, extra=["--no-browser", f"--port={port}", "--ServerApp.ip=127.0.0.1",
                                 f"--IdentityProvider.token={TOKEN}", "--LabApp.expose_app_in_browser=True"]),
        cwd=root, env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + START_LIMIT_S
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


@pytest.fixture(scope="module")
def playwright_driver():
    """One playwright driver per worker; each test launches its own browser with it."""
    sync_playwright = _playwright()
    with sync_playwright() as p:
        yield p


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


def test_validate_refuses_a_lesson(lab):
    """Validate on a lesson says it is not an exercise (the exercise path is walked in the browser, below)."""
    base, _ = lab
    status, body = _get(f"{base}/assignments/validate", data=b"path=00_tour.ipynb")
    answer = json.loads(body)
    assert status == 200 and answer["success"] is False, f"Validate on a lesson: {answer}"
    assert "lesson notebook, not an exercise" in answer["value"]
    assert _get(f"{base}/assignments/validate", data=b"path=../../etc/passwd")[0] == 403


# ---------------------------------------------------------------------------- Run All in the browser
PROBE = "probe_viewer_reports.ipynb"
PROBE_CELLS = {
    "imports": "import numpy as np  # noqa: I001 (labkit.viz.rr before rerun, as in the course)\n"
               "from labkit.viz import rr as lkrr\nimport rerun as rr",
    # the legs as rerun's Ellipses2D expects them: no report
    "good": "good = lkrr.new_recording('good leg', recording_id='probe-good')\n"
            "lkrr.show_inline(good, width=700, height=400)\n"
            "lkrr.log_static(good, 'One leg, logged as the blueprint expects it.')\n"
            "good.log('world/legs', rr.Ellipses2D(centers=[[1.0, 0.5]], half_sizes=[[0.1, 0.1]]), static=True)",
    # the legs as notebook 08 logged them before this was fixed: Points2D on an entity that labkit's
    # log_static had declared as Ellipses2D (its draw order and labels, as the old code did for every
    # feature layer); rerun draws "Component 'Ellipses2D:half_sizes' does not exist on the entity"
    "bad": "bad = lkrr.new_recording('bad leg', recording_id='probe-bad')\n"
           "lkrr.show_inline(bad, width=700, height=400)\n"
           "lkrr.log_static(bad, 'One leg, logged as points where the blueprint expects ellipses.')\n"
           "bad.log('world/legs', rr.Ellipses2D.from_fields(show_labels=False, draw_order=42.0), static=True)\n"
           "bad.log('world/legs', rr.Points2D([[1.0, 0.5]], radii=[0.07]), static=True)",
    # the same, over time, sent as columns as notebook 08 does
    "bad over time": "late = lkrr.new_recording('bad legs over time', recording_id='probe-bad-columns')\n"
                     "lkrr.show_inline(late, width=700, height=400)\n"
                     "lkrr.log_static(late, 'Three legs over time, logged as points.')\n"
                     "late.log('world/legs', rr.Ellipses2D.from_fields(show_labels=False, draw_order=42.0),\n"
                     "         static=True)\n"
                     "late.send_columns('world/legs', indexes=[rr.TimeColumn(lkrr.SEQUENCE, sequence=[0, 1, 2])],\n"
                     "                  columns=rr.Points2D.columns(positions=np.ones((3, 2))).partition([1, 1, 1]))",
}

# Where rerun's notebook widget creates its WebViewer; the test's copy of widget.js keeps each viewer
# on `window` so that the test can ask it, through the Web Viewer API (`WebViewer.get_state`, rerun
# 0.41), for the warnings and errors every view reports: the badges drawn in the canvas. It also
# counts the messages (the recording's data) the kernel sends to the viewer, which go on after the
# cell has run (rerun flushes from a thread).
WIDGET_ANCHOR = "let widget = new ViewerWidget(model, container);"
WIDGET_HOOK = (" const labkitEntry = { widget, el: container, messages: 0, last: performance.now() };"
               " model.on('msg:custom', () => { labkitEntry.messages += 1; labkitEntry.last = performance.now(); });"
               " (globalThis.__labkitRerunViewers ??= []).push(labkitEntry);")

_IDLE = """() => {
  const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
  const kernel = w && w.sessionContext && w.sessionContext.session && w.sessionContext.session.kernel;
  return !!kernel && kernel.status === 'idle';
}"""
_STARTED = "() => !!(window.jupyterapp && window.jupyterapp.commands.hasCommand('docmanager:open'))"
# A notebook opened in the running lab, the viewers of the one before forgotten; then closed, its kernel shut down
_OPEN = """async (path) => { globalThis.__labkitRerunViewers = []; await window.jupyterapp.restored;
  const w = await window.jupyterapp.commands.execute('docmanager:open', { path, factory: 'Notebook' });
  window.jupyterapp.shell.activateById(w.id);
  await w.context.ready; await w.sessionContext.ready; }"""
_CLOSE = """async () => { const w = window.jupyterapp.shell.currentWidget;
  if (w && w.sessionContext) { await w.sessionContext.shutdown(); w.dispose(); } }"""
# NotebookActions.runAll resolves once every cell has run (or was aborted after an error)
_START = """() => { window.__labkitRunAll = null;
  window.jupyterapp.commands.execute('notebook:run-all-cells').then(
    ok => { window.__labkitRunAll = { ok }; }, err => { window.__labkitRunAll = { error: String(err) }; }); }"""
_DONE = "() => window.__labkitRunAll"
_MODEL = "() => window.jupyterapp.shell.currentWidget.context.model.toJSON()"
_UNRENDERED = """() => [...document.querySelectorAll('.jp-OutputArea-output')]
  .map(o => o.innerText || '')
  .filter(t => /Error displaying widget|Loading widget|model not found/i.test(t))"""
# The viewers' frames, at most one every FRAME_MS. rerun's viewer (egui) draws a new frame on every animation
# frame the browser gives it, which in this headless Chromium (no GPU: WebGL drawn by the CPU) costs 0.6-0.7 of
# a core per viewer on the page, even with nothing changing, so a notebook's viewers starved the kernel and the
# other pytest worker. A student's browser draws on the GPU; the test asks the viewers what they hold and show,
# which does not depend on how often they draw. Only the viewer's own frame requests (the two calls of
# wasm-bindgen's glue in widget.js) are throttled; JupyterLab's are not.
FRAME_MS = 100
FRAME_CALLS = {"arg0.requestAnimationFrame(arg1)": "globalThis.__labkitFrame(arg0, arg1)",
               "arg0.cancelAnimationFrame(arg1)": "globalThis.__labkitCancelFrame(arg0, arg1)"}
FRAME_THROTTLE = f"""(() => {{
  let next = 0; const pending = new Map();  // id -> ['timer', id] then ['frame', id]
  globalThis.__labkitFrame = (w, callback) => {{
    const id = ++next;
    pending.set(id, ['timer', w.setTimeout(() => pending.set(id, ['frame', w.requestAnimationFrame(t => {{
      pending.delete(id); callback(t); }})]), {FRAME_MS})]);
    return id;
  }};
  globalThis.__labkitCancelFrame = (w, id) => {{
    const p = pending.get(id); if (!p) return;
    pending.delete(id); if (p[0] === 'timer') w.clearTimeout(p[1]); else w.cancelAnimationFrame(p[1]);
  }};
}})();"""

# Each inline viewer, scrolled into sight as a student would (it draws, and reports, when shown), asked
# what it holds once it has drawn a frame (get_state answers after the next frame).
_VIEWERS = """async () => {
  const cells = [...document.querySelectorAll('.jp-Notebook .jp-Cell')];
  const frame = () => new Promise(r => requestAnimationFrame(() => r()));
  const big = (_, v) => typeof v === 'bigint' ? v.toString() : v;
  const out = [];
  for (const { widget, el, messages, last } of (globalThis.__labkitRerunViewers || [])) {
    const cell = cells.findIndex(c => c.contains(el));
    if (!el.isConnected) { out.push({ cell, gone: true }); continue; }
    el.scrollIntoView({ block: 'center' });
    if (!widget.channel) { out.push({ cell, starting: true, messages }); continue; }  // still loading its wasm
    await frame(); await frame();
    try {
      const timeout = new Promise((_, no) => setTimeout(() => no(new Error('no answer in 15 s')), 15000));
      const s = await Promise.race([widget.viewer.get_state(), timeout]);
      out.push({ cell, messages, quiet_ms: performance.now() - last, loading: s.loading.length,
                 recordings: s.recordings.map(r => String(r.location)),
                 timelines: JSON.stringify(s.recordings.map(r => r.timelines), big) });
    } catch (e) { out.push({ cell, error: String(e) }); }
  }
  return out;
}"""
# What the views of one viewer report (the badges on their title bars) as a student scrubs through the
# active recording: paused at the start, the middle and the end of its active timeline (a report can
# depend on the time: the viewer shows the data at the time cursor).
_REPORTS = """async (index) => {
  const { widget, el } = globalThis.__labkitRerunViewers[index];
  el.scrollIntoView({ block: 'center' });
  const viewer = widget.viewer;
  let state = await viewer.get_state();
  const active = state.recordings.find(r => JSON.stringify(r.store_id) === JSON.stringify(state.active_store_id))
    || state.recordings[0];
  const timeline = active && active.current_time && active.current_time.timeline;
  const range = timeline && (active.timelines.find(t => t.name === timeline) || {}).time_range;
  const times = range ? [range.start, range.start + (range.end - range.start) / 2n, range.end] : [null];
  const reports = [];
  for (const time of times) {
    if (time !== null) {
      await viewer.set_time({ timeline, sequence: time, play_state: 'paused' });
      state = await viewer.get_state();  // the frame after the seek
    }
    state = await viewer.get_state();  // and the one after it, drawn at that time
    for (const v of state.views) for (const r of v.reports) reports.push({
      at: time === null ? '' : `${timeline}=${time}`, view: v.name, origin: v.origin, visible: v.visible,
      severity: String(r.severity), summary: r.summary, details: r.details || '' });
  }
  return reports;
}"""
# Console text by which rerun's viewer reports an error (its Rust log level, as it prints it).
RERUN_ERROR_MARKERS = (" ERROR re_", "panicked at")
RUN_LIMIT_S = 420  # per Run All, generous: two cores shared with the rest of `make test`
OPEN_LIMIT_S = 90  # for a notebook opened in the lab to show an idle kernel
VIEWER_LIMIT_S = 180  # per notebook, for its viewers to take in their data and agree twice on what they report
QUIET_S = 4  # a viewer has all its data when the kernel has sent it nothing for this long


@dataclass
class BrowserRun:
    name: str
    console: list[str] = field(default_factory=list)
    notebook: dict = field(default_factory=dict)
    unrendered: list[str] = field(default_factory=list)
    viewers: list[dict] = field(default_factory=list)
    failure: str = ""  # the run itself failed (timeout, runAll rejected)
    screenshot: Path | None = None


def _has_viewers(path: Path) -> bool:
    """Whether a notebook shows inline rerun viewers (then its first Run All is followed by the viewer probing)."""
    return any("show_inline(" in cell.source for cell in nbformat.read(path, as_version=4).cells
               if cell.cell_type == "code")


def _instrument(route) -> None:
    response = route.fetch()
    source = response.text()
    for anchor in (WIDGET_ANCHOR, *FRAME_CALLS):
        if anchor not in source:  # make the reason visible in every viewer's test
            source = f"throw new Error('labkit browser test: rerun widget.js changed, update {anchor!r}');\n" + source
    source = source.replace(WIDGET_ANCHOR, WIDGET_ANCHOR + WIDGET_HOOK, 1)
    for anchor, throttled in FRAME_CALLS.items():
        source = source.replace(anchor, throttled)
    route.fulfill(response=response, body=source)


def _settle_viewers(page, run: BrowserRun) -> None:
    """Ask the viewers until each holds a recording, has been sent nothing for QUIET_S, loads nothing
    more, and they answer the same twice (the reports are those of the data they now hold)."""
    deadline = time.monotonic() + VIEWER_LIMIT_S
    previous = None
    while True:
        states = page.evaluate(_VIEWERS)
        ready = all(s.get("gone") or s.get("error")
                    or (s.get("recordings") and not s["loading"] and s["quiet_ms"] > QUIET_S * 1000) for s in states)
        now = [{k: v for k, v in s.items() if k != "quiet_ms"} for s in states]
        if ready and now == previous:
            for k, state in enumerate(states):
                if not (state.get("gone") or state.get("error")):
                    state["reports"] = page.evaluate(_REPORTS, k)
            break
        if time.monotonic() > deadline:
            run.failure = f"the inline viewers did not settle in {VIEWER_LIMIT_S} s: {now}"
            break
        previous = now
        page.wait_for_timeout(1000)
    run.viewers = states


def _open(driver, base: str, path: str, sink: list[BrowserRun], *, viewers: bool = True):
    """A browser of its own (its page is the front one) showing ``path`` in the lab; (browser, page). The console
    goes to ``sink[0]`` (the run under way)."""
    browser = driver.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
    page = _lab_page(browser, sink, viewers=viewers)
    page.goto(f"{base}/lab/workspaces/test-{Path(path).stem}/tree/{path}?token={TOKEN}&reset")
    page.wait_for_function(_IDLE)
    return browser, page


def _lab_page(browser, sink: list[BrowserRun], *, viewers: bool = True):
    """A page in a new context of ``browser``, its console going to ``sink[0]``, rerun's widget.js instrumented."""
    context = browser.new_context(viewport={"width": 1400, "height": 1000})
    if viewers:
        context.add_init_script(FRAME_THROTTLE)
        context.route("**/widget.js", _instrument)
    page = context.new_page()
    page.set_default_timeout(180_000)
    page.on("console", lambda message: sink[0].console.append(f"{message.type}: {message.text}"))
    page.on("pageerror", lambda error: sink[0].console.append(f"pageerror: {error}"))
    return page


class SharedLab:
    """One browser per xdist worker with the lab loaded once: each notebook is opened in it, run, closed with
    its kernel shut down. JupyterLab's start (10-14 s of a notebook's time in the browser when each had a
    browser of its own) and rerun's viewer code (the 67 MB wasm compiled once per page) are paid once per
    worker. A page that crashed is replaced before the next notebook."""

    def __init__(self, driver, base: str):
        self.driver, self.base = driver, base
        self.sink = [BrowserRun("lab")]
        self.browser = self.page = None

    def open(self, path: str, run: BrowserRun):
        """The page showing ``path`` with its kernel idle. Once (make test, the 16th notebook of a worker) the
        shared page never saw the new kernel idle though the server had started it: then the notebook is opened
        again in a new browser, which the run's console notes; a second failure fails the test."""
        from playwright.sync_api import TimeoutError as PlaywrightTimeout

        self.sink[0] = run
        try:
            return self._show(path)
        except PlaywrightTimeout:
            run.console.append(f"note: {path}: no idle kernel in the shared page in {OPEN_LIMIT_S} s, "
                               "opened again in a new browser")
            self.close_browser()
        return self._show(path)

    def _show(self, path: str):
        """Open ``path`` in the page (a new browser first if there is none) and wait for its idle kernel."""
        if self.page is None or self.page.is_closed():
            self.close_browser()
            self.browser = self.driver.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            self.page = _lab_page(self.browser, self.sink)
            self.page.goto(f"{self.base}/lab/workspaces/test-shared?token={TOKEN}&reset")
            self.page.wait_for_function(_STARTED)
        self.page.evaluate(_OPEN, path)
        self.page.wait_for_function(_IDLE, timeout=OPEN_LIMIT_S * 1000)
        return self.page

    def close_notebook(self) -> None:
        if self.page is not None and not self.page.is_closed():
            try:
                self.page.evaluate(_CLOSE)
            except Exception:  # noqa: BLE001 (a page that failed to close is replaced by the next open)
                self.close_browser()

    def close_browser(self) -> None:
        if self.browser is not None:
            self.browser.close()
        self.browser = self.page = None


@pytest.fixture(scope="module")
def shared_lab(lab, playwright_driver):
    """The worker's one browser on the students' lab (see SharedLab)."""
    shared = SharedLab(playwright_driver, lab[0])
    try:
        yield shared
    finally:
        shared.close_browser()


def _run_all(page, run: BrowserRun) -> None:
    """Run All, until it has run every cell (or stopped at an error), or RUN_LIMIT_S; then read the notebook."""
    page.evaluate(_START)
    deadline = time.monotonic() + RUN_LIMIT_S
    while (done := page.evaluate(_DONE)) is None:
        if time.monotonic() > deadline:
            run.failure = f"Run All did not finish in {RUN_LIMIT_S} s"
            break
        page.wait_for_timeout(1000)
    if done is not None and "error" in done:
        run.failure = f"Run All failed: {done['error']}"
    run.notebook, run.unrendered = page.evaluate(_MODEL), page.evaluate(_UNRENDERED)


def run_twice(shared: SharedLab, name: str, shots: Path) -> tuple[BrowserRun, BrowserRun]:
    """Run All of ``name`` twice in a row in one kernel; the viewers probed after the first."""
    first, second = BrowserRun(name), BrowserRun(name)
    clock = [("start", time.monotonic())]
    page = shared.open(name, first)
    try:
        clock.append(("open", time.monotonic()))
        _run_all(page, first)
        clock.append(("first Run All", time.monotonic()))
        if not first.failure and _has_viewers(REPO / "notebooks" / name):
            _settle_viewers(page, first)
            clock.append(("viewers", time.monotonic()))
        shared.sink[0] = second
        if not first.failure:
            _run_all(page, second)
            clock.append(("second Run All", time.monotonic()))
    finally:
        first.screenshot = second.screenshot = shots / f"{name}.png"
        try:
            page.screenshot(path=str(first.screenshot))
        finally:
            shared.close_notebook()
            if _has_viewers(REPO / "notebooks" / name):  # the next notebook in a new page: twice (make test), the
                shared.close_browser()                    # one after a notebook with viewers never saw its kernel idle
    (shots / f"{name}.console.log").write_text("\n".join(first.console + ["-- second Run All --"] + second.console))
    (shots / f"{name}.viewers.json").write_text(json.dumps(first.viewers, indent=1))
    (shots / f"{name}.seconds.json").write_text(json.dumps(
        {step: round(t - before, 1) for (_, before), (step, t) in zip(clock, clock[1:], strict=False)}))
    return first, second


def _viewer_problems(run: BrowserRun) -> list[str]:
    """What a student would see go wrong in the inline viewers: error badges, dead viewers, no data."""
    problems = []
    for viewer in run.viewers:
        where = f"viewer in cell {viewer['cell']}"
        if viewer.get("gone"):
            continue  # its output was replaced, e.g. by a rerun of the cell
        if viewer.get("error"):
            problems.append(f"{where}: does not answer: {viewer['error']}")
            continue
        if viewer.get("starting"):
            problems.append(f"{where}: did not start in {VIEWER_LIMIT_S} s")
            continue
        if not viewer["recordings"]:
            problems.append(f"{where}: shows no recording")
        seen = set()
        for report in viewer.get("reports", []):
            text = f"{where}, view {report['view']!r} ({report['origin']}): {report['summary']}" + (
                f" ({report['details']})" if report["details"] else "")
            if report["severity"] == "error" and text not in seen:
                seen.add(text)
                problems.append(f"{text} [at {report['at']}]" if report["at"] else text)
    return problems


def _problems(run: BrowserRun) -> list[str]:
    problems = [run.failure] if run.failure else []
    cells = run.notebook.get("cells", [])
    not_run = [k for k, cell in enumerate(cells)
               if cell["cell_type"] == "code" and cell["source"].strip() and cell.get("execution_count") is None]
    if not_run:
        problems.append(f"cells not run by Run All: {not_run}")
    problems += [f"cell {k}: {o.get('ename')}: {o.get('evalue')}"
                 for k, cell in enumerate(cells) if cell["cell_type"] == "code"
                 for o in cell.get("outputs", []) if o["output_type"] == "error"]
    problems += [f"widget did not render: {text}" for text in run.unrendered]
    problems += _viewer_problems(run)
    problems += [f"console: {line}" for line in run.console if any(m in line for m in RERUN_ERROR_MARKERS)]
    return problems


@pytest.fixture(scope="module")
def shots(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("screenshots")


def _in_two_groups(names: list[str]) -> list:
    """The notebooks as parameters in two xdist groups (``make test`` runs ``--dist loadgroup``), so that each
    worker's one browser runs half of them: those with inline viewers (30-60 s more each) alternate between
    the groups, and so do the others. Without the groups xdist once gave all 16 to one worker (17 minutes in a
    row, the tail of make test)."""
    viewers = [n for n in names if _has_viewers(REPO / "notebooks" / n)]
    others = [n for n in names if n not in viewers]
    group = {n: f"browser-{k % 2}" for kind in (viewers, others) for k, n in enumerate(kind)}
    return [pytest.param(n, marks=pytest.mark.xdist_group(group[n])) for n in names]


@pytest.mark.parametrize("name", _in_two_groups(NOTEBOOKS))
def test_run_all_twice_in_the_browser(shared_lab, shots, name):
    """Run All, then Run All again (as a student who runs the notebook once more): no error either time."""
    first, second = run_twice(shared_lab, name, shots)
    problems = [f"first Run All: {p}" for p in _problems(first)] + [
        f"second Run All: {p}" for p in _problems(second) if first.notebook]
    assert not problems, f"{name} in the browser (screenshot {first.screenshot}):\n" + "\n".join(problems)
    if _has_viewers(REPO / "notebooks" / name):
        assert first.viewers, f"{name}: no inline rerun viewer was seen (is the widget.js hook still in place?)"
    # the docs render these outputs (docs/executed_notebooks.py) instead of running the course once more
    executed = nbformat.from_dict(second.notebook)
    for cell in executed.cells:  # JupyterLab's model says "attachments": null where nbformat wants none
        if cell.get("attachments", {}) is None:
            del cell["attachments"]
    keep_for_docs(REPO / "notebooks" / name, executed)


def test_viewer_reports_are_caught(lab, playwright_driver):
    """The detector fires: a view missing a component its visualizer needs (main's notebook 08: legs
    as Points2D under the blueprint's ellipses) fails the run, the same scene logged right does not."""
    base, root = lab
    nbformat.write(nbformat.v4.new_notebook(
        cells=[nbformat.v4.new_code_cell(source) for source in PROBE_CELLS.values()],
        metadata={"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}}),
        root / PROBE)
    run = BrowserRun(PROBE)
    browser, page = _open(playwright_driver, base, PROBE, [run])
    try:
        _run_all(page, run)
        _settle_viewers(page, run)
    finally:
        browser.close()
    cells = dict(enumerate(PROBE_CELLS))
    shown = {cells.get(v["cell"]) for v in run.viewers}
    assert shown == {"good", "bad", "bad over time"}, f"expected the three probe viewers, saw {run.viewers}"
    problems = _problems(run)
    assert problems, f"the bad probe viewers' error badges were not caught: {run.viewers}"
    for k, name in cells.items():
        mine = [p for p in problems if p.startswith(f"viewer in cell {k}, view 'Scan (sensor frame)' (/): ")]
        if name.startswith("bad"):
            assert any("Ellipses2D:half_sizes" in p for p in mine), f"{name}: {problems}"
        else:
            assert not mine, f"{name}: {mine}"
    assert all(p.startswith(("viewer in cell 2,", "viewer in cell 3,")) for p in problems), problems


# ---------------------------------------------------------------------------- the exercise path
# An exercise opened in the students' lab, its answer cells filled as a student types them, Validate clicked
# (nbgrader's toolbar button: it saves, then asks the server), the dialog read.
_FILL = """([gradeId, code]) => {
  const cells = window.jupyterapp.shell.currentWidget.content.model.cells;
  for (let i = 0; i < cells.length; i++) {
    const meta = cells.get(i).getMetadata('nbgrader');
    if (meta && meta.grade_id === gradeId) { cells.get(i).sharedModel.setSource(code); return true; }
  }
  return false;
}"""
_DIALOG = """() => {
  const m = document.querySelector('.jp-Dialog #validation-message');
  return m && { text: m.innerText, classes: [...m.classList], images: m.querySelectorAll('img').length,
                pwned: window.__labkitPwned === true };
}"""
MARKUP = '<img src=x onerror="window.__labkitPwned = true">'


def _validate(page, answers: dict[str, str]) -> dict:
    for grade_id, code in answers.items():
        assert page.evaluate(_FILL, [grade_id, code]), f"no cell {grade_id} in the exercise"
    page.locator(".validate-button jp-button, .validate-button button").first.click()
    page.wait_for_function(_DIALOG, timeout=300_000)
    page.wait_for_timeout(500)  # an image in the dialog, had it been markup, has had its chance to load and fire
    dialog = page.evaluate(_DIALOG)
    page.locator(".jp-Dialog .jp-mod-accept").first.click()
    page.wait_for_function("() => !document.querySelector('.jp-Dialog')")
    return dialog


def test_the_exercise_path_in_the_students_lab(lab, playwright_driver, shots):
    """Open exercise 1 in the students' lab, fill it and Validate: first a wrong segment beside an
    adaptive_threshold that calls labkit, tries to leave a file in the lab's folder and raises an error whose
    message is markup; then the right answer. (Two checks, not four: each costs a sandboxed grading run.)"""
    from tests.grading_course import solutions, with_mistake

    base, root = lab
    notebook = f"{EX1}.ipynb"
    marker = root / "validate_ran_student_code_here"
    right = solutions(EX1)
    hostile = {**with_mistake(EX1, "sizes >= min_points", "sizes > min_points"), "adaptive_threshold": (
        f"try:\n    open({str(marker)!r}, 'w').write('outside the sandbox')\nexcept OSError:\n    pass\n"
        "import labkit\n\n\ndef adaptive_threshold(ranges, angles, threshold_m=0.08, incidence_deg=10.0, "
        "range_sigma_m=0.01):\n    try:\n"
        "        return labkit.breakpoint_thresholds(ranges[:-1], ranges[1:], np.diff(angles), threshold_m)\n"
        "    except ModuleNotFoundError as missing:\n"
        f"        raise ValueError(f{MARKUP + ' {missing}'!r}) from None\n")}
    run = BrowserRun(notebook)
    browser, page = _open(playwright_driver, base, notebook, [run], viewers=False)
    try:
        page.wait_for_selector(".validate-button")
        hostile_said, right_said = _validate(page, hostile), _validate(page, right)
    finally:
        page.screenshot(path=str(shots / f"{notebook}.png"))
        browser.close()
    text = hostile_said["text"]
    assert "validation-failed" in hostile_said["classes"] and "Success" not in text, f"not failed: {hostile_said}"
    assert "segment: 0 of 1 points" in text and "adaptive_threshold: 0 of 1 points" in text, (
        f"the functions are not named: {text}")
    assert "Hint: the 2 m jump cuts" in text, f"the case is not named: {text}"
    assert "got array([ 0,  0,  0, -1, -1, -1, -1])" in text, f"the answer is not shown: {text}"
    assert "Traceback" not in text and "labkit/" not in text, f"a traceback into labkit: {text}"
    assert "labkit is not available when your notebook is graded" in text, f"labkit was importable: {text}"
    assert not marker.exists(), "Validate ran the student's code outside the sandbox: it wrote into the lab's folder"
    assert MARKUP in text, f"the student's message is not shown as text: {text}"
    assert not hostile_said["images"] and not hostile_said["pwned"], f"markup became HTML: {hostile_said}"
    assert "validation-success" in right_said["classes"], f"the right answer did not pass: {right_said}"
    saved = json.loads((root / notebook).read_text())
    assert any("np.hypot" in "".join(c["source"]) for c in saved["cells"]), "Validate did not save the notebook first"
