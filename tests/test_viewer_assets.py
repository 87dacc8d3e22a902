"""The inline viewer's code served from the kernel as it is on disk (labkit/viz/rr/_assets.py).

Each case runs in a fresh interpreter: rerun-notebook reads ``RERUN_NOTEBOOK_ASSET`` once, when it is first
imported, and this pytest process may have imported it already.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys

import pytest

if importlib.util.find_spec("rerun_notebook") is None:  # (not imported here: its import reads the variable)
    pytest.skip("rerun-notebook is not installed", allow_module_level=True)

PROBE = r"""
import json, os, sys, time, urllib.error, urllib.request
from labkit.viz.rr import _assets
started = time.process_time()
url = _assets.serve()
again = _assets.serve()
report = {"url": url, "again": again, "env": os.environ.get("RERUN_NOTEBOOK_ASSET"), "files": {}, "refused": {}}
if url:
    for name in ("widget.js", "re_viewer_bg.wasm"):
        with urllib.request.urlopen(url.replace("widget.js", name)) as r:
            report["files"][name] = [len(r.read()), r.headers["Content-Type"], r.headers["Access-Control-Allow-Origin"]]
    for path in ("/", "/../static/widget.js", "/widget.css", "/%2e%2e/__init__.py"):
        try:
            urllib.request.urlopen(url.replace("/widget.js", path))
            report["refused"][path] = False
        except urllib.error.HTTPError as err:
            report["refused"][path] = err.code
import rerun_notebook
report["esm"] = str(rerun_notebook.ESM_MOD)
report["cpu_s"] = time.process_time() - started
report["static"] = os.path.join(os.path.dirname(rerun_notebook.__file__), "static")
print(json.dumps(report))
"""


def _probe(asset: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "RERUN_NOTEBOOK_ASSET"}
    if asset is not None:
        env["RERUN_NOTEBOOK_ASSET"] = asset
    p = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.splitlines()[-1])


@pytest.mark.parametrize("asset", ["serve-local", None])  # None: importing labkit.viz.rr sets serve-local
def test_serve_local_is_served_from_disk_without_compressing(asset):
    got = _probe(asset)
    assert got["url"].startswith("http://localhost:") and got["url"].endswith("/widget.js")
    assert got["again"] == got["url"] == got["env"] == got["esm"]  # one server; rerun-notebook loads from it
    for name, (size, kind, origin) in got["files"].items():
        assert size == os.path.getsize(os.path.join(got["static"], name))  # the file as it is, uncompressed
        assert kind == {"widget.js": "text/javascript", "re_viewer_bg.wasm": "application/wasm"}[name]
        assert origin == "*"
    assert got["refused"] == dict.fromkeys(got["refused"], 404)  # those two files and nothing else
    assert got["cpu_s"] < 2.0, got  # rerun-notebook's own serve-local gzips the 67 MB viewer: ~4 s


def test_any_other_setting_is_left_alone():
    asset = "https://example.invalid/notebook/widget.js"
    got = _probe(asset)
    assert got["url"] is None and got["again"] is None and got["env"] == asset == got["esm"]


def test_a_kernel_that_imported_rerun_notebook_already_is_left_alone():
    code = ("import os; os.environ['RERUN_NOTEBOOK_ASSET'] = 'https://example.invalid/widget.js'; "
            "import rerun_notebook; os.environ['RERUN_NOTEBOOK_ASSET'] = 'serve-local'; "
            "from labkit.viz.rr import _assets; "
            "print(_assets.serve(), os.environ['RERUN_NOTEBOOK_ASSET'])")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and p.stdout.split() == ["None", "serve-local"], p.stderr
