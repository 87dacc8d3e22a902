"""Start the student's worker in a sandbox and talk to it: the only door between the grader and student code.

The worker (``worker.py`` beside this file) runs under `bubblewrap <https://github.com/containers/bubblewrap>`_
(``bwrap``) in new pid, network, IPC, UTS and mount namespaces. It sees:

- the Python runtime that runs the grader (``sys.base_prefix``, read-only) and the system's shared
  libraries (``/usr/lib``, read-only), with every other ``site-packages`` / ``dist-packages`` of the
  machine hidden;
- the virtualenv's site-packages (read-only) with the *masked* packages replaced by a stub that
  raises ``ModuleNotFoundError`` (labkit always; an exercise adds more, e.g. scikit-learn), and
  every ``__editable__`` finder stubbed too (labkit's editable install points into the repository);
- an empty ``/tmp`` (a size-capped tmpfs, the working directory), ``/proc`` of its own pid
  namespace and a minimal ``/dev``; no network but loopback; no environment but a few variables
  set here (``--clearenv``).

Not the repository, not ``exercises/`` (sources, specs, gradebook, other submissions), not the
home directory, not ``/etc``, no shell. ``--die-with-parent`` and the pid namespace make killing
the outer ``bwrap`` process (or the grader) kill every process of the sandbox.

When the grader runs as root, bwrap keeps only ``CAP_SETUID``/``CAP_SETGID`` and the worker drops
to an unprivileged uid (``nobody``, 65534, and unused uids below it for parallel jobs) before any
student byte runs, so ``RLIMIT_NPROC`` holds (the kernel does not enforce it for uid 0) and the
student owns nothing. As another user bwrap makes a user namespace and the worker runs as uid
65534 inside it (your own uid outside), with ``RLIMIT_NPROC`` counting your processes too. The
worker also sets CPU seconds, address space, file size, open files and processes limits
(:class:`Limits`). On x86_64 a seccomp filter (``seccomp_filter``) refuses the system calls
that would outlive the sandbox (keyrings), escape the memory limit (``memfd_create``) or widen the
kernel's attack surface (new namespaces, ``ptrace``, ``bpf``, ``io_uring``, ...) or leave the CPUs it was given
(``sched_setaffinity``).

Where the grader may make cgroups (root, cgroup v1 or v2: :mod:`labkit.grading.cgroups`), every
worker's whole sandbox is in a cgroup of its own: its processes together hold at most the memory
limit (swap and its tmpfs files included; beyond it the kernel kills one of *them*), make at most
``processes`` processes and threads, and use at most ``cpus`` CPUs, as one entity for the
scheduler (31 forked busy loops get the share of one process, not 31). Elsewhere only the
per-process rlimits hold, with fewer processes (``UNGROUPED_PROCESSES``), and each parallel
job's workers are pinned to a CPU of their own (inherited from the trusted process at ``fork``;
the seccomp filter keeps the student from widening it).

:class:`Worker` is one running worker; :class:`Session` grades one submission with as many
workers as it takes (a fresh one after a call that timed out or killed its worker).
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import pwd
import select
import shutil
import signal
import site
import struct
import subprocess
import sys
import sysconfig
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from . import protocol
from .cgroups import WorkerCgroup
from .cgroups import detect as cgroup_support

__all__ = [
    "Limits",
    "Sandbox",
    "Worker",
    "Session",
    "WorkerLost",
    "CallTimedOut",
    "WorkerCrashed",
    "SandboxBroken",
    "BudgetUsed",
    "check_bwrap",
]

HERE = Path(__file__).resolve().parent
WORKER_FILES = ("worker.py", "protocol.py")
INSTALL_HINT = "install bubblewrap (Debian/Ubuntu: `sudo apt-get install bubblewrap`)"
STARTUP_TIMEOUT_S = 60.0  # bwrap + python + numpy; generous, as a loaded machine can be slow
#: All of a notebook's cells together may take this many times the time one cell may.
LOAD_BUDGET = 6
#: After SIGINT, how long a cell past its time has to stop before its worker is killed.
INTERRUPT_GRACE_S = 2.0
#: Cells that ignore the interrupt or crash the worker while the notebook runs: each is left out and the
#: notebook run again; beyond this many, none of its functions can be called.
MAX_STOPPED_CELLS = 3
#: Processes and threads of a worker where there is no cgroup (RLIMIT_NPROC): each may hold the whole
#: address-space limit, so together they may hold this many times it.
UNGROUPED_PROCESSES = 8


class WorkerLost(BaseException):
    """The worker stopped answering: a call timed out, or the worker died or broke the protocol.

    A ``BaseException``, so that no ``except Exception`` in a test can swallow it: the test fails.
    """


class CallTimedOut(WorkerLost):
    """A call (or loading the notebook) ran past its time; the worker was killed."""


class WorkerCrashed(WorkerLost):
    """The worker died (exit, signal, resource limit) or sent something that is not the protocol."""


class SandboxBroken(RuntimeError):
    """The sandbox could not start a worker at all: the grader's problem, not the student's."""


@dataclass(frozen=True)
class Limits:
    """Resource limits of one worker (``setrlimit``, soft = hard), and the size of its ``/tmp``.

    Parameters
    ----------
    cpu_s : int
        CPU seconds of the worker process (``RLIMIT_CPU``; it is killed by SIGXCPU beyond).
    memory_bytes : int
        Address space of each process (``RLIMIT_AS``: a larger allocation raises ``MemoryError`` in the
        student's code) and, in a cgroup, the memory of all the sandbox's processes and its ``/tmp`` and
        ``/dev/shm`` files together (beyond it the kernel kills one of its processes).
    file_bytes : int
        Largest file the student may write (``RLIMIT_FSIZE``).
    open_files : int
        ``RLIMIT_NOFILE``.
    processes : int
        Processes and threads of the sandbox (cgroup ``pids``) and of the worker's uid (``RLIMIT_NPROC``;
        at most ``UNGROUPED_PROCESSES`` where there is no cgroup): a fork bomb stops there.
    tmp_bytes : int
        Size of the tmpfs mounted on ``/tmp``, the working directory.
    shm_bytes : int
        Size of the tmpfs mounted on ``/dev/shm`` (for ``multiprocessing``).
    cpus : int
        CPUs all the sandbox's processes together may use at once (a cgroup CPU quota).
    """

    cpu_s: int = 120
    memory_bytes: int = 2 << 30
    file_bytes: int = 64 << 20
    open_files: int = 128
    processes: int = 32
    tmp_bytes: int = 128 << 20
    shm_bytes: int = 64 << 20
    cpus: int = 1

    def rlimits(self, *, grouped: bool = True) -> dict[str, int]:
        """The worker's ``setrlimit`` values; ``grouped``: whether its sandbox is in a cgroup of its own."""
        return {
            "RLIMIT_CORE": 0,
            "RLIMIT_CPU": self.cpu_s,
            "RLIMIT_AS": self.memory_bytes,
            "RLIMIT_FSIZE": self.file_bytes,
            "RLIMIT_NOFILE": self.open_files,
            "RLIMIT_NPROC": self.processes if grouped else min(self.processes, UNGROUPED_PROCESSES),
        }


def check_bwrap() -> str:
    """The path of ``bwrap``, or FileNotFoundError saying how to install it.

    Returns
    -------
    str
        The path of the ``bwrap`` executable.
    """
    path = shutil.which("bwrap")
    if path is None:
        raise FileNotFoundError(
            f"labkit grade runs student code in a bubblewrap sandbox, and bwrap is not installed: {INSTALL_HINT}"
            " (or pass --no-sandbox to run student code unisolated, at your own risk)"
        )
    return path


@functools.cache
def worker_uid(slot: int) -> int:
    """The unprivileged uid of parallel job ``slot``: ``nobody`` (65534), then unused uids below it."""
    free = [65534]
    for uid in range(65533, 60000, -1):
        if len(free) > slot:
            break
        if not _uid_exists(uid):
            free.append(uid)
    return free[slot % len(free)]


def _uid_exists(uid: int) -> bool:
    try:
        pwd.getpwuid(uid)
    except KeyError:
        return False
    return True


@functools.lru_cache(maxsize=1)
def _runtime() -> tuple[str, str, tuple[str, ...], tuple[str, ...]]:
    """(interpreter, runtime prefix, site-packages to show, Python package folders to hide)."""
    python = os.path.realpath(sys.executable)
    prefix = os.path.realpath(sys.base_prefix)
    shown = tuple(dict.fromkeys(os.path.realpath(p) for p in site.getsitepackages() if os.path.isdir(p)))
    hidden = [os.path.realpath(p) for p in site.getsitepackages([sys.base_prefix, sys.base_exec_prefix])]
    for root in ("/usr/lib", "/usr/local/lib"):
        if os.path.isdir(root):
            hidden += [os.path.join(root, name) for name in os.listdir(root) if name.startswith("python")]
    hidden = [p for p in dict.fromkeys(hidden) if os.path.isdir(p) and p not in shown]
    stdlib = os.path.realpath(sysconfig.get_path("stdlib"))
    hidden = [p for p in hidden if not (stdlib + os.sep).startswith(p + os.sep)]
    return python, prefix, shown, tuple(hidden)


@functools.lru_cache(maxsize=1)
def _stubs() -> tuple[str, str]:
    """A stub module file and a stub package folder that raise ModuleNotFoundError when imported."""
    folder = tempfile.mkdtemp(prefix="labkit-grading-stubs-")
    os.chmod(folder, 0o755)
    text = 'raise ModuleNotFoundError(f"{__name__} is not available when your notebook is graded")\n'
    module = os.path.join(folder, "stub.py")
    package = os.path.join(folder, "package")
    os.mkdir(package, 0o755)
    for path in (module, os.path.join(package, "__init__.py")):
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        os.chmod(path, 0o644)
    return module, package


def _masked_entries(site_dir: str, masked: tuple[str, ...]) -> list[tuple[str, bool]]:
    """Entries of ``site_dir`` that provide a masked top-level name, as (name, is_folder)."""
    found = []
    for name in sorted(os.listdir(site_dir)):
        path = os.path.join(site_dir, name)
        module = name.split(".")[0]
        if name.startswith("__editable__") or module in masked and (
            os.path.isdir(path) or name.endswith((".py", ".pyc", ".so", ".pth"))
        ):
            found.append((name, os.path.isdir(path)))
    return found


class Sandbox:
    """How to start workers for one exercise: the bwrap command line, or a plain process with ``isolate=False``.

    Parameters
    ----------
    masked : tuple of str
        Top-level packages the student's code must not import (labkit is always added).
    limits : Limits
        The resource limits of each worker.
    slot : int
        Parallel job number: picks the worker's uid (see ``worker_uid``).
    isolate : bool
        False runs the worker as a plain subprocess with the same limits, a scrubbed environment,
        an empty temporary working directory and (as root, when the Python runtime is readable by
        other users) an unprivileged uid, but without namespaces: it can read every file its uid
        can, reach the network and import the masked packages by path. For instructors who accept
        that risk (``--no-sandbox``).
    user_namespace : bool or None
        Use a user namespace instead of dropping root (the only way as another user; None picks
        by the current uid).
    cgroups : bool
        Put each worker in a cgroup of its own where the machine allows it (see
        :func:`labkit.grading.cgroups.detect`); False never does (for tests of the fallback).
    """

    def __init__(
        self,
        masked: tuple[str, ...] = (),
        *,
        limits: Limits = Limits(),
        slot: int = 0,
        isolate: bool = True,
        user_namespace: bool | None = None,
        cgroups: bool = True,
    ) -> None:
        self.masked = tuple(dict.fromkeys(("labkit", *masked)))
        self.limits = limits
        self.isolate = isolate
        self.user_namespace = os.getuid() != 0 if user_namespace is None else user_namespace
        self.uid = worker_uid(slot)
        self.gid = 65534
        self.bwrap = check_bwrap() if isolate else None
        self._plain_dir: str | None = None
        found = cgroup_support() if cgroups else None
        self.cgroups = found if found is not None and found.usable else None
        #: Without a cgroup CPU quota, the CPU this job's workers are pinned to (one per parallel job).
        self.cpu = None if self.cgroups is not None and "cpu" in self.cgroups.controllers else _slot_cpu(slot)

    def _config(self, site_dirs: list[str], *, drop: bool) -> str:
        return json.dumps({
            "limits": self.limits.rlimits(grouped=self.cgroups is not None),
            "uid": self.uid if drop else None,
            "gid": self.gid if drop else None,
            "site": site_dirs,
            "masked": list(self.masked),
        })

    def command(self, seccomp_fd: int | None = None, info_fd: int | None = None
                ) -> tuple[list[str], dict[str, str] | None, str | None]:
        """(argv, environment, working directory) of a new worker; ``seccomp_fd`` is a file descriptor
        bwrap reads the seccomp filter from (see ``seccomp_filter``), ``info_fd`` one it writes the
        sandbox's pids to."""
        python, prefix, shown, hidden = _runtime()
        if not self.isolate:
            return self._plain_command(python, shown)
        assert self.bwrap is not None, "__init__ finds bwrap when the sandbox isolates"
        args = [self.bwrap, "--die-with-parent", "--new-session", "--unshare-pid", "--unshare-net",
                "--unshare-ipc", "--unshare-uts", "--unshare-cgroup-try", "--hostname", "grader"]
        if self.user_namespace:
            args += ["--unshare-user", "--uid", "65534", "--gid", "65534"]
        else:
            args += ["--cap-drop", "ALL", "--cap-add", "CAP_SETUID", "--cap-add", "CAP_SETGID"]
        args += ["--clearenv"]
        for name, value in _ENVIRONMENT.items():
            args += ["--setenv", name, value]
        made: set[str] = set()

        def folder(path: str) -> None:  # every folder bwrap makes: world-readable (it uses 0700)
            for parent in reversed(Path(path).parents):
                if str(parent) != "/" and str(parent) not in made:
                    args.extend(["--perms", "0755", "--dir", str(parent)])
                    made.add(str(parent))
            if path not in made:
                args.extend(["--perms", "0755", "--dir", path])
                made.add(path)

        for link in ("/lib", "/lib64", "/lib32", "/bin"):
            if os.path.islink(link):
                args += ["--symlink", os.readlink(link), link]
        for libs in ("/usr/lib", "/usr/lib64", "/usr/lib32", "/lib", "/lib64"):
            if os.path.isdir(libs) and not os.path.islink(libs):
                folder(libs)
                args += ["--ro-bind", libs, libs]
        folder(prefix)
        args += ["--ro-bind", prefix, prefix]
        if not python.startswith(prefix + os.sep):
            folder(os.path.dirname(python))
            args += ["--ro-bind", python, python]
        for path in hidden:
            args += ["--tmpfs", path]
        args += ["--ro-bind-try", "/etc/ld.so.cache", "/etc/ld.so.cache"]
        module_stub, package_stub = _stubs()
        site_dirs = []
        for index, real in enumerate(shown):
            inside = f"/opt/site{index}"
            folder(inside)
            args += ["--ro-bind", real, inside]
            for name, is_folder in _masked_entries(real, self.masked):
                args += ["--ro-bind", package_stub if is_folder else module_stub, f"{inside}/{name}"]
            site_dirs.append(inside)
        folder("/grader")
        for name in WORKER_FILES:
            args += ["--ro-bind", str(HERE / name), f"/grader/{name}"]
        args += ["--proc", "/proc", "--dev", "/dev", "--size", str(self.limits.tmp_bytes), "--perms", "1777",
                 "--tmpfs", "/tmp", "--size", str(self.limits.shm_bytes), "--perms", "1777", "--tmpfs", "/dev/shm",
                 "--chdir", "/tmp"]
        if seccomp_fd is not None:
            args += ["--seccomp", str(seccomp_fd)]
        if info_fd is not None:
            args += ["--info-fd", str(info_fd)]
        config = self._config(site_dirs, drop=not self.user_namespace)
        return [*args, "--", python, "-I", "-S", "-B", "/grader/worker.py", config], None, None

    def _plain_command(self, python: str, shown: tuple[str, ...]) -> tuple[list[str], dict[str, str], str]:
        if self._plain_dir is None:
            self._plain_dir = tempfile.mkdtemp(prefix="labkit-grading-worker-")
            os.chmod(self._plain_dir, 0o755)
            for name in WORKER_FILES:
                shutil.copy(HERE / name, os.path.join(self._plain_dir, name))
        workdir = tempfile.mkdtemp(prefix="labkit-grading-cwd-")
        drop = os.getuid() == 0 and all(_world_readable(p) for p in (sys.base_prefix, *shown, self._plain_dir))
        if drop:
            os.chown(workdir, self.uid, self.gid)
        environment = dict(_ENVIRONMENT, HOME=workdir, TMPDIR=workdir, MPLCONFIGDIR=f"{workdir}/.matplotlib")
        config = self._config(list(shown), drop=drop)
        return [python, "-I", "-S", "-B", os.path.join(self._plain_dir, "worker.py"), config], environment, workdir


def _slot_cpu(slot: int) -> int | None:
    """The CPU of parallel job ``slot``: this process's CPUs in turn."""
    try:
        cpus = sorted(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return None
    return cpus[slot % len(cpus)] if cpus else None


def _world_readable(path: str) -> bool:
    """True when every folder down to ``path`` lets other users through (an unprivileged uid can import from it)."""
    real = Path(os.path.realpath(path))
    return all(os.stat(folder).st_mode & 0o005 == 0o005 for folder in [*real.parents, real])


_ENVIRONMENT = {
    "HOME": "/tmp",
    "TMPDIR": "/tmp",
    "LANG": "C.UTF-8",
    "MPLBACKEND": "Agg",
    "MPLCONFIGDIR": "/tmp/.matplotlib",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "PYTHONDONTWRITEBYTECODE": "1",
}


# ---------------------------------------------------------------------------- seccomp
#: System calls the student's code may not make (x86_64 numbers), and why:
DENIED_SYSCALLS = {
    # the kernel's keyrings belong to a uid, not to a sandbox: a channel to the next submission
    "add_key": 248, "request_key": 249, "keyctl": 250,
    # memory that RLIMIT_AS does not count (POSIX shared memory is the 64 MB /dev/shm)
    "memfd_create": 319, "memfd_secret": 447, "shmget": 29, "shmat": 30,
    # other processes' memory
    "ptrace": 101, "process_vm_readv": 310, "process_vm_writev": 311,
    # new namespaces (unprivileged user namespaces are a large attack surface), mounts
    "unshare": 272, "setns": 308, "mount": 165, "umount2": 166, "pivot_root": 155, "chroot": 161,
    # the CPUs a job's workers are pinned to where there is no cgroup CPU quota (widening them would take
    # the neighbours' CPUs)
    "sched_setaffinity": 203,
    # kernel interfaces no exercise needs, each a known source of privilege escalations
    "userfaultfd": 323, "perf_event_open": 298, "bpf": 321, "io_uring_setup": 425, "io_uring_enter": 426,
    "io_uring_register": 427, "kexec_load": 246, "kexec_file_load": 320, "init_module": 175,
    "finit_module": 313, "delete_module": 176, "open_by_handle_at": 304,
}
_CLONE, _CLONE3 = 56, 435
_CLONE_NEW_NAMESPACES = 0x7E020000  # CLONE_NEWNS | NEWCGROUP | NEWUTS | NEWIPC | NEWUSER | NEWPID | NEWNET


@functools.cache
def seccomp_filter() -> bytes | None:
    """The classic BPF program bwrap loads with ``--seccomp`` (x86_64; None elsewhere).

    It refuses :data:`DENIED_SYSCALLS` with EPERM, ``clone`` with a new-namespace flag with EPERM,
    ``clone3`` with ENOSYS (its flags are behind a pointer; glibc then falls back to ``clone``),
    any other architecture's or the x32 ABI's system calls, and allows the rest.
    """
    if os.uname().machine != "x86_64":
        return None
    load, jump_eq, jump_ge, jump_set, ret = 0x20, 0x15, 0x35, 0x45, 0x06
    allow, eperm, enosys = 0x7FFF0000, 0x00050000 | 1, 0x00050000 | 38
    # (op, jump if true, jump if false, k); an op that is a string is a label: the next instruction's name
    program: list[tuple[int | str, int | str, int | str, int]] = [
        (load, 0, 0, 4),  # seccomp_data.arch
        (jump_eq, 0, "deny", 0xC000003E),  # AUDIT_ARCH_X86_64
        (load, 0, 0, 0),  # seccomp_data.nr
        (jump_ge, "deny", 0, 0x40000000),  # the x32 ABI
        (jump_eq, "no clone3", 0, _CLONE3),
        (jump_eq, "clone", 0, _CLONE),
        *[(jump_eq, "deny", 0, number) for number in sorted(DENIED_SYSCALLS.values())],
        (ret, 0, 0, allow),
        ("clone", 0, 0, 0),
        (load, 0, 0, 16),  # the low half of args[0]: clone's flags
        (jump_set, "deny", 0, _CLONE_NEW_NAMESPACES),
        (ret, 0, 0, allow),
        ("deny", 0, 0, 0),
        (ret, 0, 0, eperm),
        ("no clone3", 0, 0, 0),
        (ret, 0, 0, enosys),
    ]
    labels: dict[str, int] = {}
    code: list[tuple[int, int | str, int | str, int]] = []
    for op, true, false, k in program:
        if isinstance(op, str):
            labels[op] = len(code)
        else:
            code.append((op, true, false, k))

    def offset(target: int | str, here: int) -> int:
        return target if isinstance(target, int) else labels[target] - here - 1

    return b"".join(struct.pack("=HBBI", op, offset(true, i), offset(false, i), k)
                    for i, (op, true, false, k) in enumerate(code))


def _describe_exit(code: int | None) -> str:
    if code is None:
        return "stopped answering"
    signum = -code if code < 0 else code - 128 if code > 128 else None
    reasons = {
        signal.SIGKILL: "killed (SIGKILL)",
        signal.SIGXCPU: "stopped at its CPU time limit (SIGXCPU)",
        signal.SIGXFSZ: "stopped at its file size limit (SIGXFSZ)",
        signal.SIGSEGV: "crashed (segmentation fault; a recursion too deep?)",
        signal.SIGABRT: "aborted (SIGABRT)",
    }
    if signum is not None and signum > 0:
        try:
            return reasons.get(signal.Signals(signum), f"killed by signal {signal.Signals(signum).name}")
        except ValueError:
            pass
    return f"exited with status {code}"


@contextlib.contextmanager
def _pinned(cpu: int | None):
    """Run the block (a fork) on ``cpu`` only, so that the child inherits it; this thread's CPUs after."""
    if cpu is None:
        yield
        return
    previous = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {cpu})
    try:
        yield
    finally:
        os.sched_setaffinity(0, previous)


_LIVE: set[Worker] = set()  # the workers this process started and has not killed yet


def kill_all_workers() -> None:
    """Kill every worker this process still has (their sandboxes, cgroups and folders): a grading process
    told to stop (SIGTERM from the run, on Ctrl-C) calls it before it exits."""
    for worker in list(_LIVE):
        with contextlib.suppress(Exception):
            worker.kill()


class Worker:
    """One running worker process and its channel (stdin/stdout pipes of length-prefixed JSON frames).

    Parameters
    ----------
    sandbox : Sandbox
        How to start it.
    """

    def __init__(self, sandbox: Sandbox) -> None:
        program = seccomp_filter() if sandbox.isolate else None
        seccomp_fd = None
        if program is not None:  # bwrap reads the filter from a pipe (a few hundred bytes: it fits)
            seccomp_fd, write_end = os.pipe()
            os.write(write_end, program)
            os.close(write_end)
        self._info: int | None = None
        info_fd: int | None = None
        if sandbox.isolate:
            self._info, info_fd = os.pipe()
        if self._info is not None:
            os.set_blocking(self._info, False)
        argv, environment, workdir = sandbox.command(seccomp_fd, info_fd)
        self.workdir = workdir
        self.errors = tempfile.TemporaryFile()
        self.memory_bytes = sandbox.limits.memory_bytes
        self.cpu_s: float | None = None  # the CPU seconds its sandbox used, once it ended (where known)
        self.cgroup: WorkerCgroup | None = None
        started = time.perf_counter()
        try:
            if sandbox.cgroups is not None:
                limits = sandbox.limits
                self.cgroup = sandbox.cgroups.create(limits.memory_bytes, limits.processes, limits.cpus)
                argv = self.cgroup.command(argv)
            with _pinned(sandbox.cpu):
                self.process = subprocess.Popen(
                    argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.errors, env=environment or {},
                    cwd=workdir, start_new_session=True, close_fds=True,
                    pass_fds=[fd for fd in [seccomp_fd, info_fd] if fd is not None],
                )
        except BaseException as error:  # no cgroup, no process (or Ctrl-C): leave nothing behind
            self.errors.close()
            self._release()
            if isinstance(error, OSError):  # the machine's problem, not the student's
                raise SandboxBroken(f"the sandbox could not start a worker: {error}") from None
            raise
        finally:
            for fd in (seccomp_fd, info_fd):
                if fd is not None:
                    os.close(fd)
        _LIVE.add(self)
        stdin, stdout = self.process.stdin, self.process.stdout
        assert stdin is not None and stdout is not None, "Popen(stdin=PIPE, stdout=PIPE)"
        self._out = stdin.fileno()
        self._in = stdout.fileno()
        os.set_blocking(self._out, False)
        os.set_blocking(self._in, False)
        self._readable, self._writable = select.poll(), select.poll()
        self._readable.register(self._in, select.POLLIN)
        self._writable.register(self._out, select.POLLOUT)
        self._pending = bytearray()  # bytes read beyond the last frame
        self._init_pid: int | None = None
        self._next_id = 1
        try:
            hello = self._receive(time.monotonic() + STARTUP_TIMEOUT_S)
        except WorkerLost:
            message = self.stderr() or "no message"
            self.kill()
            raise SandboxBroken(f"the sandbox could not start a worker: {message}") from None
        except BaseException:  # Ctrl-C while it starts
            self.kill()
            raise
        if "hello" not in hello:
            self.kill()
            raise SandboxBroken(f"the worker said {str(hello)[:200]} instead of hello")
        self.uid = hello.get("uid")
        self.start_s = time.perf_counter() - started

    def stderr(self) -> str:
        """What bwrap and the worker's bootstrap wrote to stderr (the student's stderr goes to /dev/null)."""
        self.errors.seek(0)
        return self.errors.read(4000).decode("utf-8", "replace").strip()

    # ------------------------------------------------------------------ channel
    @staticmethod
    def _wait(poller: select.poll, deadline: float) -> None:
        left = deadline - time.monotonic()
        if left <= 0 or not poller.poll(int(left * 1000) + 1):
            raise CallTimedOut("timed out")

    def _send(self, message: dict, deadline: float) -> None:
        view = memoryview(protocol.pack(message))
        while view:
            try:
                view = view[os.write(self._out, view):]
            except BlockingIOError:
                self._wait(self._writable, deadline)
            except (BrokenPipeError, ConnectionResetError):
                raise WorkerCrashed(self._died()) from None

    def _read(self, size: int, deadline: float) -> bytes:
        while len(self._pending) < size:
            try:
                chunk = os.read(self._in, 1 << 20)
            except BlockingIOError:
                self._wait(self._readable, deadline)
                continue
            if not chunk:
                raise WorkerCrashed(self._died())
            self._pending += chunk
        data = bytes(self._pending[:size])
        del self._pending[:size]
        return data

    def _receive(self, deadline: float) -> dict:
        try:
            return protocol.unpack(self._read(protocol.frame_length(self._read(4, deadline)), deadline))
        except protocol.ProtocolError as error:
            raise WorkerCrashed(f"sent something that is not the grader's protocol ({error})") from None

    def _died(self) -> str:
        try:
            code = self.process.wait(timeout=2)
        except subprocess.TimeoutExpired:
            code = None
        killed = self.cgroup.oom_kills() if self.cgroup is not None else 0
        if killed:
            return (f"was killed at its memory limit ({self.memory_bytes >> 20} MB for all the processes of its"
                    f" sandbox together; {killed} of them killed)")
        return _describe_exit(code)

    # ------------------------------------------------------------------ requests
    def load(self, cells: list[str], deadline: float, first: int = 0) -> list[dict]:
        """Run the student's code cells (numbered from ``first``); the cells that raised, as
        ``{"cell", "error", "message"}``."""
        self._send({"op": "load", "cells": cells, "first": first}, deadline)
        return self.receive_load(deadline)

    def receive_load(self, deadline: float) -> list[dict]:
        """The answer to a ``load`` (also after :meth:`interrupt`)."""
        reply = self._receive(deadline)
        errors = reply.get("errors")
        try:
            if type(errors) is not list:
                raise protocol.ProtocolError("not a list of errors")
            return [_cell_error(error) for error in errors[:100]]
        except protocol.ProtocolError as problem:
            raise WorkerCrashed(f"answered the notebook with something that is not the protocol ({problem})") from None

    def call(self, name: str, args: tuple, kwargs: dict, deadline: float) -> Any:
        """``name(*args, **kwargs)`` in the worker: its result decoded, or the exception it raised rebuilt."""
        request = {"op": "call", "id": self._next_id, "name": name,
                   "args": protocol.encode(list(args)), "kwargs": protocol.encode(dict(kwargs))}
        self._next_id += 1
        self._send(request, deadline)
        reply = self._receive(deadline)
        try:
            if reply.get("id") != request["id"] or len(reply) != 2:
                raise protocol.ProtocolError("an answer to another question")
            if "value" in reply:
                return protocol.decode(reply["value"])
            raised = reply.get("raised")
            if type(raised) is not dict:
                raise protocol.ProtocolError("an answer with neither value nor exception")
            error = protocol.rebuild_exception(raised.get("types"), raised.get("message"))
        except protocol.ProtocolError as problem:
            raise WorkerCrashed(f"sent something that is not the grader's protocol ({problem})") from None
        raise error

    def interrupt(self) -> None:
        """Send the worker SIGINT (a KeyboardInterrupt in the cell it runs), as Jupyter's interrupt would."""
        pid = self.process.pid
        if self._info is not None:  # the worker is the child of bwrap's init, whose pid bwrap told
            with contextlib.suppress(OSError, ValueError, KeyError):
                if self._init_pid is None:
                    self._init_pid = json.loads(os.read(self._info, 4096))["child-pid"]
                with open(f"/proc/{self._init_pid}/task/{self._init_pid}/children", encoding="ascii") as f:
                    pid = int(f.read().split()[0])
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.kill(pid, signal.SIGINT)

    def _reported_cpu_seconds(self) -> float:
        """The CPU seconds the worker says it used (a number for timings, nothing is decided on it)."""
        try:
            self._send({"op": "usage"}, time.monotonic() + 1)
            seconds = self._receive(time.monotonic() + 1).get("cpu")
        except WorkerLost:
            return 0.0
        return float(seconds) if (type(seconds) is int or type(seconds) is float) and 0 <= seconds < 1e6 else 0.0

    def close(self) -> None:
        """End the worker by closing its channel (it returns, bwrap ends its sandbox), else kill it."""
        if self.cgroup is None:  # no CPU accounting of the sandbox: the worker's own word
            self.cpu_s = self._reported_cpu_seconds()
        try:
            if self.process.stdin is not None:  # (always: Popen(stdin=PIPE))
                self.process.stdin.close()
            self.process.wait(timeout=2)
        except (OSError, subprocess.TimeoutExpired):
            pass
        self.kill()

    def kill(self) -> None:
        """Kill the worker and everything in its sandbox (its whole cgroup, where it has one); wait for it."""
        if self.process.poll() is None:  # not reaped yet: its pid (the group's id) is not anyone else's
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.process.pid, signal.SIGKILL)
        if self.cgroup is not None:
            self.cgroup.kill()
        self.process.wait()
        for stream in (self.process.stdin, self.process.stdout, self.errors):
            try:
                if stream is not None:  # (always: Popen(stdin=PIPE, stdout=PIPE))
                    stream.close()
            except OSError:
                pass
        self._release()

    def _release(self) -> None:
        """Remove what the worker leaves behind: its cgroup (after reading its CPU time), pipe and folder."""
        _LIVE.discard(self)
        if self.cgroup is not None:
            self.cpu_s = self.cgroup.cpu_seconds()
            self.cgroup.remove()
            self.cgroup = None
        if self._info is not None:
            os.close(self._info)
            self._info = None
        if self.workdir:
            shutil.rmtree(self.workdir, ignore_errors=True)
            self.workdir = None


def _cell_error(error: Any) -> dict:
    if type(error) is not dict or type(error.get("cell")) is not int:
        raise protocol.ProtocolError("an error entry without its cell")
    exception = protocol.rebuild_exception(error.get("types"), error.get("message"))
    return {"cell": error["cell"], "error": type(exception).__name__, "message": str(exception)}


@dataclass
class Timing:
    """Where one submission's time went (seconds)."""

    start_s: float = 0.0  # starting workers (bwrap, python, numpy)
    worker_cpu_s: float = 0.0  # CPU of the workers' sandboxes (their cgroups; without, what the workers that ended
    # normally reported)
    load_s: float = 0.0  # running the student's cells
    calls_s: float = 0.0  # waiting for the student's functions (including the channel)
    workers: int = 0


class BudgetUsed(CallTimedOut):
    """The time for all of a submission's calls (``submission_timeout_s`` of :class:`Session`) is used up."""


class Session:
    """The student's functions for one submission: the notebook run once, a worker replaced after a loss.

    :meth:`load` runs the notebook's code cells in a fresh worker before any test, with a time budget of its
    own: ``load_timeout_s`` per cell and ``LOAD_BUDGET`` times that for all of them. A cell past its time
    is interrupted (a KeyboardInterrupt in the cell, as Jupyter's interrupt) and the cells after it still run;
    one that ignores the interrupt, or crashes the worker, is left out and the notebook runs again without it
    (at most ``MAX_STOPPED_CELLS`` times); cells still waiting when the budget is used up are not run. The
    functions the cells that ran defined are graded either way; its ``cell_errors`` say what happened.

    Calls go through :meth:`call`, each within ``call_timeout_s``, the current test's calls together within
    its budget (:meth:`begin_test`), and all the submission's calls, with the notebook run again after a
    lost worker, within ``submission_timeout_s`` (the trusted side's own work counts against none of them). A
    call that times out or kills its worker raises :class:`WorkerLost`; further calls in the same test fail at
    once with the same loss, and the next test gets a fresh worker that runs the cells again. So one
    submission takes at most the load budget, plus ``submission_timeout_s``, plus an interrupt's grace
    (``INTERRUPT_GRACE_S``) per stopped cell, the starts of its workers and the trusted side's own work.

    Parameters
    ----------
    sandbox : Sandbox
        How to start the workers.
    cells : list of str
        The notebook's code cells, in order.
    load_timeout_s : float
        The time limit of each cell when the notebook runs, seconds.
    call_timeout_s : float
        The time limit of each call, seconds.
    submission_timeout_s : float
        The time limit of all the submission's calls together, seconds.
    """

    def __init__(self, sandbox: Sandbox, cells: list[str], *, load_timeout_s: float, call_timeout_s: float,
                 submission_timeout_s: float = float("inf")) -> None:
        self.sandbox = sandbox
        self.cells = cells
        self.load_timeout_s = load_timeout_s
        self.call_timeout_s = call_timeout_s
        self.submission_timeout_s = submission_timeout_s
        self.worker: Worker | None = None
        self.cell_errors: list[dict] | None = None
        self.load_failure: WorkerLost | None = None
        self.stopped_cells: set[int] = set()
        self.unrun_cells: set[int] = set()
        self.test_failure: WorkerLost | None = None
        self.test_budget_s = float("inf")  # the current test's calls may take this long together
        self.test_spent_s = 0.0
        self.spent_s = 0.0  # calls and reloads, counted against submission_timeout_s
        self.timed_out = False
        self.crashed = False
        self.timing = Timing()

    def begin_test(self, budget_s: float) -> None:
        """A new test: its calls together may take ``budget_s`` (the trusted side's own work is not counted)."""
        self.test_budget_s = budget_s
        self.test_spent_s = 0.0
        self.test_failure = None

    def _lose(self, lost: WorkerLost) -> WorkerLost:
        if isinstance(lost, CallTimedOut):
            self.timed_out = True
        else:
            self.crashed = True
        if self.worker is not None:
            self.worker.kill()
            self.timing.worker_cpu_s += self.worker.cpu_s or 0.0
            self.worker = None
        return lost

    # ------------------------------------------------------------------ running the notebook
    def load(self) -> None:
        """Run the notebook's cells in a fresh worker, within the load budget (see the class); once."""
        if self.cell_errors is not None:
            return
        budget_s = self.load_timeout_s * LOAD_BUDGET
        budget = time.monotonic() + budget_s
        errors: dict[int, dict] = {}
        while True:
            worker = self._start()
            stopped = None
            for index, source in enumerate(self.cells):
                if index in self.stopped_cells:
                    continue
                if time.monotonic() >= budget:  # used up between two cells: as much "timed out" as within one
                    self.unrun_cells = {i for i in range(index, len(self.cells)) if i not in self.stopped_cells}
                    self.timed_out = True
                    break
                stopped = self._run_cell(worker, index, source, min(time.monotonic() + self.load_timeout_s, budget),
                                         budget_s, errors)
                if stopped is not None:
                    break
            if stopped is None:
                break
            errors[stopped["cell"]] = stopped
            self.stopped_cells.add(stopped["cell"])
            if len(self.stopped_cells) > MAX_STOPPED_CELLS or time.monotonic() >= budget:
                self.load_failure = WorkerCrashed(
                    f"your notebook's cells could not be run ({stopped['message']}; {len(self.stopped_cells)} cells "
                    f"stopped in {time.monotonic() - budget + budget_s:.0f} s), so none of its functions could be"
                    " called")
                break
        for index in sorted(self.unrun_cells):
            errors[index] = {"cell": index, "error": "TimeoutError", "message": f"not run: the notebook's cells had"
                             f" used their {budget_s:g} s (the cells before it ran, and their functions are graded)"}
        self.cell_errors = [errors[index] for index in sorted(errors)]

    def _run_cell(self, worker: Worker, index: int, source: str, deadline: float, budget_s: float,
                  errors: dict[int, dict]) -> dict | None:
        """Run one cell; None when the worker went on (the cell's error noted), else the note of a cell that had to
        be stopped (the worker is then gone)."""
        started = time.monotonic()
        try:
            for error in worker.load([source], deadline, index):
                errors[error["cell"]] = error
            return None
        except CallTimedOut:
            ran = time.monotonic() - started
            whole = (f"the notebook's cells had used their {budget_s:g} s" if ran < self.load_timeout_s - 0.01
                     else f"the limit is {self.load_timeout_s:g} s per cell")
            self.timed_out = True
            if self._interrupted(worker):
                errors[index] = {"cell": index, "error": "TimeoutError", "message": f"this cell ran {ran:.0f} s and "
                                 f"was interrupted ({whole}); the cells after it still ran"}
                return None
            self._lose(CallTimedOut("a cell ran too long"))
            return {"cell": index, "error": "TimeoutError", "message": f"this cell ran {ran:.0f} s ({whole}) and went "
                    "on after the interrupt: it was stopped, and the notebook ran again without it"}
        except WorkerCrashed as crash:
            self._lose(crash)
            return {"cell": index, "error": "WorkerCrashed", "message": f"the process running this cell "
                    f"{crash.args[0] if crash.args else 'died'}: the notebook ran again without it"}
        finally:
            self.timing.load_s += time.monotonic() - started

    def _interrupted(self, worker: Worker) -> bool:
        """Interrupt the cell that ran past its time; True when the worker then went on."""
        worker.interrupt()
        try:
            worker.receive_load(time.monotonic() + INTERRUPT_GRACE_S)
        except CallTimedOut:
            return False  # it ignores KeyboardInterrupt
        except WorkerCrashed:
            return False
        return True

    def _reload(self) -> Worker:
        """A fresh worker with the cells that ran at first run again (after a lost worker): charged to the
        submission's time."""
        started = time.monotonic()
        try:
            worker = self._start()
            for index, source in enumerate(self.cells):
                if index in self.stopped_cells or index in self.unrun_cells:
                    continue
                left = self.submission_timeout_s - self.spent_s - (time.monotonic() - started)
                deadline = time.monotonic() + min(self.load_timeout_s, max(left, 0.0))
                try:
                    worker.load([source], deadline, index)
                except CallTimedOut:
                    if time.monotonic() - started + self.spent_s >= self.submission_timeout_s:
                        raise self._budget_used() from None
                    if not self._interrupted(worker):
                        raise
            return worker
        finally:
            self.spent_s += time.monotonic() - started
            self.timing.load_s += time.monotonic() - started

    def _budget_used(self) -> BudgetUsed:
        return BudgetUsed(f"not run: the {self.submission_timeout_s:g} s for all of your submission's calls (and the"
                          " notebook run again after a call that timed out or crashed) were used up")

    def _ready_worker(self) -> Worker:
        if self.cell_errors is None:
            self.load()
        if self.load_failure is not None:
            raise type(self.load_failure)(*self.load_failure.args)
        if self.worker is not None:
            return self.worker
        if self.spent_s >= self.submission_timeout_s:
            raise self._budget_used()
        try:
            self.worker = self._reload()
        except BudgetUsed as used:
            self._lose(used)
            raise
        except CallTimedOut:
            raise self._lose(CallTimedOut("running your notebook's cells again (after a lost worker) took too"
                                          " long")) from None
        except WorkerCrashed as crash:
            raise self._lose(WorkerCrashed(f"the process running your notebook {crash.args[0]} while running its"
                                           " cells again")) from None
        return self.worker

    def _start(self) -> Worker:
        worker = Worker(self.sandbox)
        self.worker = worker
        self.timing.workers += 1
        self.timing.start_s += worker.start_s
        return worker

    # ------------------------------------------------------------------ calls
    def call(self, name: str, args: tuple, kwargs: dict) -> Any:
        if self.test_failure is not None:
            raise type(self.test_failure)(*self.test_failure.args)
        try:
            worker = self._ready_worker()  # a reload is the submission's time, not this test's
        except WorkerLost as lost:
            self.test_failure = lost
            raise
        if self.spent_s >= self.submission_timeout_s:
            self.test_failure = self._budget_used()
            raise type(self.test_failure)(*self.test_failure.args)
        started = time.monotonic()
        limits = {"call": self.call_timeout_s, "test": self.test_budget_s - self.test_spent_s,
                  "submission": self.submission_timeout_s - self.spent_s}
        which = min(limits, key=limits.__getitem__)
        try:
            return worker.call(name, args, kwargs, started + max(limits[which], 0.0))
        except CallTimedOut:
            if which == "submission":
                self.test_failure = self._lose(self._budget_used())
            else:
                limit = "this test's time" if which == "test" else f"{self.call_timeout_s:g} s"
                self.test_failure = self._lose(CallTimedOut(
                    f"{name}(...) did not return within {limit}; it was stopped and this test scores 0"))
            raise type(self.test_failure)(*self.test_failure.args) from None
        except WorkerCrashed as crash:
            self.test_failure = self._lose(WorkerCrashed(
                f"the process running your code {crash.args[0]} during {name}(...); this test scores 0"))
            raise type(self.test_failure)(*self.test_failure.args) from None
        finally:
            elapsed = time.monotonic() - started
            self.spent_s += elapsed
            self.test_spent_s += elapsed
            self.timing.calls_s += elapsed

    def close(self) -> None:
        if self.worker is not None:
            self.worker.close()
            self.timing.worker_cpu_s += self.worker.cpu_s or 0.0
            self.worker = None

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def describe_limits(limits: Limits) -> dict[str, int]:
    """The limits as a plain dict (for records)."""
    return asdict(limits)
