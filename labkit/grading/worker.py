"""The student's side of the grader: run one submission's code cells, then answer calls to its functions.

This file runs inside the sandbox as a plain script (``python -I -S worker.py CONFIG``), beside
``protocol.py``; it imports the standard library, numpy and ``protocol`` only, and there is no
labkit where it runs. Its first lines are the grader's: they move the protocol off stdin and
stdout (the student's prints go to ``/dev/null``), set the resource limits, drop root to the
unprivileged user the grader chose and make the masked packages unimportable with a clear
message. Only then does it read the student's code:

1. ``{"op": "load", "cells": [source, ...], "first": n}``: the code cells (numbered from ``n``; the
   grader sends one at a time, each with its own time limit) run in order in one namespace, as
   Jupyter's *Run All* would (IPython magics and ``!`` lines do nothing; a cell that raises is
   recorded and the next one runs). The answer lists the cells that raised.
2. ``{"op": "call", "id": n, "name": f, "args": [...], "kwargs": {...}}``: the answer is
   ``{"id": n, "value": ...}`` or ``{"id": n, "raised": {"types": [...], "message": ...}}``.

Nothing here is trusted once the student's code ran: the student can replace any of it. The
trusted grader therefore believes only what :func:`protocol.decode` builds from the bytes.
"""

from __future__ import annotations

import ast
import json
import os
import re
import signal
import sys
import types
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # for mypy only: the protocol.py beside this file, which the functions below import by path
    from labkit.grading import protocol  # noqa: F401 -- (there is no labkit where the worker runs)

CHANNEL_IN = 0
CHANNEL_OUT = 1
# IPython syntax: a line starting with % or ! (after spaces), or ending with ?. Spaces and tabs only, not \s:
# `^\s*` runs over every following blank line from every line start, quadratic in a run of blank lines (20 000
# of them took seconds, where no interrupt reaches).
_MAGIC = re.compile(r"^[ \t]*[%!]|\?[ \t]*$", re.M)
_RUN_BODY_MAGICS = frozenset({"time", "timeit", "capture", "prun"})  # cell magics whose body is Python


def _read_exact(fd: int, size: int) -> bytes:
    chunks, left = [], size
    while left:
        chunk = os.read(fd, min(left, 1 << 20))
        if not chunk:
            raise EOFError("the grader closed the channel")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _limit(limits: dict[str, int]) -> None:
    import resource

    for name, value in limits.items():
        resource.setrlimit(getattr(resource, name), (value, value))


def _drop_privileges(uid: int | None, gid: int | None) -> None:
    """Become ``uid``/``gid`` for good (no supplementary groups); refuse to go on as root."""
    if uid is None:  # nothing to drop (a user namespace, or no sandbox)
        return
    if gid is None:
        raise SystemExit(f"worker: told to drop to uid {uid} without a gid")
    if os.getuid() == 0:
        os.setgroups([])
        os.setresgid(gid, gid, gid)
        os.setresuid(uid, uid, uid)
    if os.getresuid() != (uid, uid, uid) or os.getresgid() != (gid, gid, gid):
        raise SystemExit(f"worker: could not drop to uid {uid}, gid {gid}")
    if uid != 0 and 0 in os.getresuid():
        raise SystemExit("worker: still root after dropping privileges")


def _unavailable(name: str) -> ModuleNotFoundError:
    top = name.partition(".")[0]
    return ModuleNotFoundError(
        f"{top} is not available when your notebook is graded ({name}): this exercise asks you to write the"
        " computation yourself (numpy is fine)",
        name=name,
    )


class _Unavailable:
    """A meta path finder that turns ``import <masked>`` into a ModuleNotFoundError saying why.

    Only a message: the masked packages are not in the sandbox at all, so removing this finder
    gives the plain "No module named ..." instead.
    """

    def __init__(self, names: list[str]) -> None:
        self.names = frozenset(names)

    def find_spec(self, fullname, path=None, target=None):
        if fullname.partition(".")[0] in self.names:
            raise _unavailable(fullname)
        return None


class _Missing:
    """What an unguarded top-level ``import labkit`` (or ``from labkit import x``) binds in a cell: the
    import costs nothing, any use of the name raises ModuleNotFoundError saying why."""

    def __init__(self, name: str) -> None:
        object.__setattr__(self, "_name", name)

    def __getattr__(self, attribute: str):
        if attribute.startswith("__"):
            raise AttributeError(attribute)
        raise _unavailable(f"{self._name}.{attribute}")

    def __call__(self, *args, **kwargs):
        raise _unavailable(self._name)

    def __repr__(self) -> str:
        return f"<{self._name}: not available when graded>"


_MISSING = "__labkit_grading_missing__"


def without_masked_imports(tree: ast.Module, masked: frozenset[str]) -> ast.Module:
    """``tree`` with its top-level imports of masked packages turned into :class:`_Missing` names.

    Only imports directly in the cell's body: one inside ``try`` (a student's fallback), a function
    or a class still raises ImportError, so ``except ImportError:`` takes its other road.
    """
    body: list[ast.stmt] = []
    for node in tree.body:
        bound: list[tuple[str, str]] = []  # (name bound, what it stands for)
        if isinstance(node, ast.Import):
            kept = [alias for alias in node.names if alias.name.partition(".")[0] not in masked]
            bound = [(alias.asname or alias.name.partition(".")[0], alias.name if alias.asname
                      else alias.name.partition(".")[0]) for alias in node.names if alias not in kept]
            if kept:
                body.append(ast.copy_location(ast.Import(names=kept), node))
        elif isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").partition(".")[0] in masked:
            bound = [(alias.asname or alias.name, f"{node.module}.{alias.name}") for alias in node.names
                     if alias.name != "*"]
        else:
            body.append(node)
            continue
        for name, standing_for in bound:
            call = ast.Call(ast.Name(_MISSING, ast.Load()), [ast.Constant(standing_for)], [])
            body.append(ast.copy_location(ast.Assign([ast.Name(name, ast.Store())], call), node))
    tree.body = body
    return ast.fix_missing_locations(tree)


class _Shell:
    """What ``get_ipython()`` returns in the worker: magics and shell commands do nothing.

    ``%%time``, ``%%timeit``, ``%%capture`` and ``%%prun`` run their body once (it is Python), and
    ``%time`` / ``%timeit`` their statement.
    """

    def __init__(self, namespace: dict) -> None:
        self.user_ns = namespace

    def run_line_magic(self, name, line, *args, **kwargs):
        if name in _RUN_BODY_MAGICS and line.strip():
            exec(compile(line, "<magic>", "exec"), self.user_ns)

    def run_cell_magic(self, name, line, cell, *args, **kwargs):
        if name in _RUN_BODY_MAGICS:
            exec(compile(cell, "<magic>", "exec"), self.user_ns)

    def system(self, *args, **kwargs):
        return None

    def getoutput(self, *args, **kwargs):
        return []


def python_source(source: str) -> str:
    """A cell's source with IPython's syntax (magics, ``!cmd``, ``obj?``) turned into plain Python."""
    if not _MAGIC.search(source):
        return source
    try:
        from IPython.core.inputtransformer2 import TransformerManager
    except ImportError:  # no IPython: drop the lines IPython would have rewritten
        return "\n".join(
            line[: len(line) - len(line.lstrip())] + "pass" if _MAGIC.search(line) else line
            for line in source.splitlines()
        )
    return TransformerManager().transform_cell(source)


def _raised(error: BaseException) -> dict:
    if not TYPE_CHECKING:
        import protocol

    try:
        message = str(error)
    except BaseException:  # noqa: BLE001 -- a student's __str__ may raise anything
        message = f"<{type(error).__name__} that cannot be printed>"
    return {"types": protocol.exception_names(error), "message": message[: protocol.MAX_MESSAGE_CHARS]}


def _load(cells: list[str], namespace: dict, masked: frozenset[str], first: int = 0) -> dict:
    """Run cells in ``namespace``; a SIGINT from the grader (a cell past its time) interrupts only them."""
    errors = []
    for index, source in enumerate(cells, first):
        try:
            tree = without_masked_imports(ast.parse(python_source(source), f"<cell {index}>"), masked)
            code = compile(tree, f"<cell {index}>", "exec")
            while signal.sigtimedwait([signal.SIGINT], 0) is not None:
                pass  # an interrupt meant for an earlier cell
            signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT])
            try:
                exec(code, namespace)
            finally:
                signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGINT])
        except BaseException as error:  # noqa: BLE001 -- as in Jupyter: record it, run the next cell
            errors.append({"cell": index, **_raised(error)})
    return {"errors": errors}


def _call(message: dict, namespace: dict) -> bytes:
    """The answer to one call, as a frame."""
    if not TYPE_CHECKING:
        import protocol

    name = message["name"]
    try:
        function = namespace.get(name)
        if not callable(function):
            raise NameError(f"{name} is not defined in your notebook (keep the function's name and signature)")
        result = function(*protocol.decode(message["args"]), **protocol.decode(message["kwargs"]))
        try:
            return protocol.pack({"id": message["id"], "value": protocol.encode(result)})
        except (TypeError, ValueError, RecursionError) as error:
            raise TypeError(f"{name} returned something the grader cannot compare: {error}") from None
    except BaseException as error:  # noqa: BLE001 -- the student's error goes back to the grader as data
        return protocol.pack({"id": message["id"], "raised": _raised(error)})


def serve(config: dict) -> None:
    """Bootstrap (limits, privileges, masks), then load the student's cells and answer calls until EOF."""
    channel_in, channel_out = os.dup(CHANNEL_IN), os.dup(CHANNEL_OUT)
    devnull = os.open(os.devnull, os.O_RDWR)
    os.dup2(devnull, CHANNEL_IN)
    os.dup2(devnull, CHANNEL_OUT)
    _limit(config["limits"])
    _drop_privileges(config["uid"], config["gid"])
    sys.path.extend(config["site"])
    sys.meta_path.insert(0, _Unavailable(config["masked"]))
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import numpy  # noqa: F401 -- imported once here, so that the student's cells find it warm

    if not TYPE_CHECKING:
        import protocol

    del sys.path[0]  # the student's code sees the runtime and site-packages only

    def send(message: dict) -> None:
        _write_all(channel_out, protocol.pack(message))

    def receive() -> dict:
        return protocol.unpack(_read_exact(channel_in, protocol.frame_length(_read_exact(channel_in, 4))))

    # KeyboardInterrupt on SIGINT even when the grader was started with SIGINT ignored (`labkit grade &` in a
    # script: a shell starts background commands so, and Python keeps an ignored SIGINT ignored)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGINT])  # only while a cell runs (see _load)
    send({"hello": os.getpid(), "uid": os.getuid()})
    masked = frozenset(config["masked"])
    main = types.ModuleType("__main__")
    shell = _Shell(main.__dict__)
    main.__dict__[_MISSING] = _Missing
    main.__dict__["get_ipython"] = lambda: shell
    main.__dict__["display"] = lambda *objects, **options: None  # Jupyter's builtin: nothing to show here
    sys.modules["__main__"] = main
    while True:
        try:
            message = receive()
        except EOFError:
            return
        if message.get("op") == "load":
            os.dup2(devnull, 2)  # from here on only the student writes to stderr
            send(_load(message["cells"], main.__dict__, masked, message.get("first", 0)))
        elif message.get("op") == "call":
            _write_all(channel_out, _call(message, main.__dict__))
        elif message.get("op") == "usage":  # CPU seconds, for the grader's timings only
            import resource

            usage = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
            send({"cpu": sum(u.ru_utime + u.ru_stime for u in usage)})


if __name__ == "__main__":
    serve(json.loads(sys.argv[1]))
