"""The inline viewer's code served to the browser from the kernel, as the files are on disk.

``RERUN_NOTEBOOK_ASSET=serve-local`` (what :mod:`labkit.viz.rr` and ``labkit lab`` set, so that the viewer
loads offline) makes rerun-notebook gzip its 67 MB WebAssembly viewer in memory when it is first imported:
4.2 s of CPU, and as long a wait, at the first inline viewer of every kernel, and both copies kept in the
kernel's memory. The browser and the kernel are on one machine (serve-local binds ``localhost`` too), where
compressing saves nothing. So before rerun-notebook is first imported, :func:`serve` starts a small HTTP
server in a thread of this process that sends the package's two files (``widget.js`` and the viewer's
``.wasm`` next to it) from disk, and points ``RERUN_NOTEBOOK_ASSET`` at it. A variable set to anything
else (a URL, ``inline``) is left alone, and so is a kernel that has imported rerun-notebook already.
"""

from __future__ import annotations

import http.server
import importlib.util
import os
import shutil
import sys
import threading
from pathlib import Path

SERVE_LOCAL = "serve-local"
FILES = {"/widget.js": ("widget.js", "text/javascript"),
         "/re_viewer_bg.wasm": ("re_viewer_bg.wasm", "application/wasm")}
_url: str | None = None
_lock = threading.Lock()


def _static() -> Path | None:
    """rerun-notebook's folder of static files, found without importing the package (its import reads the variable)."""
    spec = importlib.util.find_spec("rerun_notebook")
    if spec is None or spec.origin is None:
        return None
    static = Path(spec.origin).parent / "static"
    return static if all((static / name).is_file() for name, _ in FILES.values()) else None


class _Handler(http.server.BaseHTTPRequestHandler):
    static: Path

    def _head(self) -> Path | None:
        found = FILES.get(self.path.split("?", 1)[0])
        if found is None:
            self.send_error(404)
            return None
        name, kind = found
        path = self.static / name
        self.send_response(200)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(path.stat().st_size))
        self.send_header("Access-Control-Allow-Origin", "*")  # the lab's page is on another port
        self.end_headers()
        return path

    def do_HEAD(self) -> None:  # noqa: N802 (http.server's name)
        self._head()

    def do_GET(self) -> None:  # noqa: N802
        path = self._head()
        if path is not None:
            with open(path, "rb") as fh:
                shutil.copyfileobj(fh, self.wfile, 1 << 20)

    def log_message(self, format: str, *args) -> None:  # noqa: A002 (http.server's signature)
        pass  # a kernel's stderr is the student's notebook


def serve() -> str | None:
    """Serve the viewer's code from this process if rerun-notebook would gzip it; the URL of ``widget.js`` or None.

    Returns None, and changes nothing, when ``RERUN_NOTEBOOK_ASSET`` is not ``serve-local``, when
    rerun-notebook is imported already (it has read the variable) or is not installed.
    """
    global _url
    with _lock:
        if _url is not None:
            return _url
        if os.environ.get("RERUN_NOTEBOOK_ASSET") != SERVE_LOCAL or "rerun_notebook" in sys.modules:
            return None
        static = _static()
        if static is None:
            return None
        handler = type("Handler", (_Handler,), {"static": static})
        server = http.server.ThreadingHTTPServer(("localhost", 0), handler)
        server.daemon_threads = True
        threading.Thread(target=server.serve_forever, name="labkit-viewer-assets", daemon=True).start()
        _url = f"http://localhost:{server.server_address[1]}/widget.js"
        os.environ["RERUN_NOTEBOOK_ASSET"] = _url
        return _url
