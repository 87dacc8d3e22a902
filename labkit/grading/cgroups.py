"""A control group per worker: memory, processes and CPU of a whole sandbox, where the machine lets the grader make one.

``setrlimit`` limits each process on its own: a worker that forks 31 children holds 32 times
its memory limit, and 31 busy loops, each in a session of its own, take 31 shares of the CPUs
from the student graded next to it. A cgroup limits the sandbox as a whole. :func:`detect` finds
out once per process whether the grader may make cgroups (as root, cgroup v1 -- one hierarchy
per controller, as on this machine -- or cgroup v2, one unified tree); :meth:`Cgroups.create`
then makes one per worker, *under the grader's own cgroup*, with

- ``memory``: all the sandbox's processes together, and the files in its ``/tmp`` and
  ``/dev/shm`` (tmpfs pages are charged to it), hold at most the limit, swap included; beyond it
  the kernel's OOM killer kills a process *of that sandbox* (the worker: that test crashes);
- ``pids``: at most that many processes and threads in the sandbox;
- ``cpu``: the sandbox is one entity for the scheduler (forks and new sessions do not multiply
  its share) and may use at most ``cpus`` CPUs at once (a CFS quota);
- CPU accounting: the CPU seconds of every process the sandbox ever ran, read by the trusted side.

The worker joins its cgroup before ``bwrap`` starts (:meth:`WorkerCgroup.command`: a ``/bin/sh``
that writes its own pid into ``cgroup.procs`` and execs the real command), so that every process
of the sandbox is born inside. :meth:`WorkerCgroup.remove` kills whatever is left in it and
removes it; a cgroup of a grader that died (SIGKILL, a power cut) is removed by the next
:func:`detect` on the machine (its name carries its owner's pid and start time).
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import os
import re
import signal
import time
from dataclasses import dataclass, field

__all__ = ["Cgroups", "WorkerCgroup", "detect", "PREFIX"]

PREFIX = "labkit-grading-"
_WORKER = re.compile(rf"^{PREFIX}(\d+)-(\d+)-w\d+$")
_TRUSTED = f"{PREFIX}trusted"  # cgroup v2: the leaf the grader moves itself into (see _delegate)
REQUIRED = ("memory", "pids")
OPTIONAL = ("cpu", "cpuacct")
CPU_PERIOD_US = 100_000
REMOVE_TIMEOUT_S = 5.0


@dataclass(frozen=True)
class Cgroups:
    """What the grader may do with cgroups on this machine.

    Parameters
    ----------
    version : int or None
        1 or 2; None when no cgroup can be made (then :attr:`problem` says why).
    parents : dict
        Controller -> the folder under which workers' cgroups are made (cgroup v1: one per
        hierarchy, ``cpu`` and ``cpuacct`` may share one; v2: the same folder for all).
    problem : str
        Why cgroups are not used ("" when they are).
    """

    version: int | None
    parents: dict[str, str] = field(default_factory=dict)
    problem: str = ""

    @property
    def usable(self) -> bool:
        return self.version is not None

    @property
    def controllers(self) -> frozenset[str]:
        return frozenset(self.parents)

    def create(self, memory_bytes: int, processes: int, cpus: int) -> WorkerCgroup:
        """A new cgroup for one worker, with its limits set. Raises OSError when the kernel refuses."""
        if self.version is None:  # not usable: a worker would run with no cgroup limit at all
            raise OSError(f"no cgroup can be made on this machine: {self.problem}")
        name = f"{PREFIX}{os.getpid()}-{_start_time(os.getpid())}-w{next(_COUNTER)}"
        folders = {}
        try:
            for parent in dict.fromkeys(self.parents.values()):
                folder = os.path.join(parent, name)
                os.mkdir(folder, 0o755)
                folders[parent] = folder
            group = WorkerCgroup(self.version, {c: folders[p] for c, p in self.parents.items()})
            group.limit(memory_bytes, processes, cpus)
        except BaseException:
            for folder in folders.values():
                _remove_folder(folder)
            raise
        return group


_COUNTER = itertools.count(1)


@dataclass
class WorkerCgroup:
    """The cgroup (one folder per v1 hierarchy) of one worker.

    Parameters
    ----------
    version : int
        The cgroup version, 1 or 2.
    folders : dict of str to str
        Controller -> its folder (one folder for every controller with version 2).
    """

    version: int
    folders: dict[str, str]  # controller -> folder

    def _file(self, controller: str, name: str) -> str | None:
        folder = self.folders.get(controller)
        return None if folder is None else os.path.join(folder, name)

    def limit(self, memory_bytes: int, processes: int, cpus: int) -> None:
        """Write the limits (memory with swap, processes, CPU quota)."""
        if self.version == 1:
            _write(self._file("memory", "memory.limit_in_bytes"), memory_bytes)
            _write(self._file("memory", "memory.memsw.limit_in_bytes"), memory_bytes, optional=True)  # swap
            _write(self._file("pids", "pids.max"), processes)
            if "cpu" in self.folders:
                _write(self._file("cpu", "cpu.cfs_period_us"), CPU_PERIOD_US)
                _write(self._file("cpu", "cpu.cfs_quota_us"), CPU_PERIOD_US * cpus)
        else:
            _write(self._file("memory", "memory.max"), memory_bytes)
            _write(self._file("memory", "memory.swap.max"), 0, optional=True)
            _write(self._file("pids", "pids.max"), processes)
            if "cpu" in self.folders:
                _write(self._file("cpu", "cpu.max"), f"{CPU_PERIOD_US * cpus} {CPU_PERIOD_US}")

    @property
    def procs_files(self) -> list[str]:
        return [os.path.join(folder, "cgroup.procs") for folder in dict.fromkeys(self.folders.values())]

    def command(self, argv: list[str]) -> list[str]:
        """``argv`` started inside this cgroup: a shell joins it, then becomes ``argv`` (same pid)."""
        script = 'while [ "$1" != -- ]; do echo $$ > "$1" || exit 125; shift; done; shift; exec "$@"'
        return ["/bin/sh", "-c", script, "labkit-grading-cgroup", *self.procs_files, "--", *argv]

    def pids(self) -> set[int]:
        found = set()
        for path in self.procs_files:
            with contextlib.suppress(OSError, ValueError):
                with open(path, encoding="ascii") as f:
                    found |= {int(line) for line in f.read().split()}
        return found

    def cpu_seconds(self) -> float | None:
        """CPU seconds every process of the sandbox used, or None where there is no CPU accounting."""
        if self.version == 1:
            text = _read(self._file("cpuacct", "cpuacct.usage"))
            return int(text) / 1e9 if text and text.strip().isdigit() else None
        found = re.search(r"^usage_usec (\d+)$", _read(self._file("cpu", "cpu.stat")) or
                          _read(self._file("memory", "cpu.stat")) or "", re.M)
        return int(found.group(1)) / 1e6 if found else None

    def oom_kills(self) -> int:
        """How many processes of the sandbox the kernel killed at its memory limit."""
        text = _read(self._file("memory", "memory.oom_control" if self.version == 1 else "memory.events")) or ""
        found = re.search(r"^oom_kill (\d+)$", text, re.M)
        return int(found.group(1)) if found else 0

    def kill(self) -> None:
        """SIGKILL every process in the cgroup (cgroup v2's ``cgroup.kill`` where there is one)."""
        kill_file = self._file("pids", "cgroup.kill") if self.version == 2 else None
        if kill_file and os.path.exists(kill_file):
            with contextlib.suppress(OSError):
                _write(kill_file, 1)
                return
        for pid in self.pids():
            _kill_member(pid, self)

    def remove(self) -> None:
        """Kill what is left in the cgroup and remove it (waiting a little for the processes to go)."""
        deadline = time.monotonic() + REMOVE_TIMEOUT_S
        for folder in dict.fromkeys(self.folders.values()):
            _remove_folder(folder, deadline, self)


def _kill_member(pid: int, group: WorkerCgroup) -> None:
    """SIGKILL ``pid`` through a pidfd, once it is known to be in ``group`` (a pid that was reused meanwhile is
    not signalled)."""
    try:
        pidfd = os.pidfd_open(pid)
    except OSError:
        return
    try:
        if pid in group.pids():
            signal.pidfd_send_signal(pidfd, signal.SIGKILL)
    except OSError:
        pass
    finally:
        os.close(pidfd)


def _remove_folder(folder: str, deadline: float | None = None, group: WorkerCgroup | None = None) -> None:
    """rmdir ``folder``; while processes are still in it, kill them (``group``) and retry until ``deadline``."""
    deadline = deadline or time.monotonic() + REMOVE_TIMEOUT_S
    while True:
        try:
            os.rmdir(folder)
            return
        except FileNotFoundError:
            return
        except OSError:
            if time.monotonic() > deadline:
                return  # left for the next detect() to remove
        if group is not None:
            group.kill()
        time.sleep(0.01)


def _write(path: str | None, value: object, *, optional: bool = False) -> None:
    if path is None:
        return
    try:
        with open(path, "w", encoding="ascii") as f:
            f.write(f"{value}\n")
    except OSError:
        if not (optional and not os.path.exists(path)):
            raise


def _read(path: str | None) -> str | None:
    if path is None:
        return None
    try:
        with open(path, encoding="ascii") as f:
            return f.read()
    except OSError:
        return None


def _start_time(pid: int) -> int | None:
    """The start time of process ``pid`` (clock ticks since boot), or None when there is no such process."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as f:
            return int(f.read().rpartition(")")[2].split()[19])
    except (OSError, ValueError, IndexError):
        return None


# ---------------------------------------------------------------------------- finding the cgroups
def _mounts(mountinfo: str) -> list[tuple[str, str, str, set[str]]]:
    """(fstype, root, mount point, options) of every cgroup file system in ``/proc/self/mountinfo``."""
    found = []
    for line in mountinfo.splitlines():
        head, _, tail = line.partition(" - ")
        fields, rest = head.split(), tail.split()
        if len(fields) >= 5 and len(rest) >= 3 and rest[0] in ("cgroup", "cgroup2"):
            unescape = functools.partial(re.sub, r"\\([0-7]{3})", lambda m: chr(int(m.group(1), 8)))
            found.append((rest[0], unescape(fields[3]), unescape(fields[4]), set(rest[2].split(","))))
    return found


def _inside(mount_root: str, mount_point: str, path: str) -> str | None:
    """The folder of cgroup ``path`` under a mount of the hierarchy's ``mount_root``, or None."""
    if path != mount_root and not path.startswith(mount_root.rstrip("/") + "/"):
        return None
    return os.path.join(mount_point, os.path.relpath(path, mount_root)).rstrip("/.") or mount_point


def _can_make_folders(parent: str) -> bool:
    probe = os.path.join(parent, f"{PREFIX}probe-{os.getpid()}")
    try:
        os.mkdir(probe)
    except FileExistsError:
        pass
    except OSError:
        return False
    with contextlib.suppress(OSError):
        os.rmdir(probe)
    return True


def _v1(mounts, cgroups: dict[str, str]) -> tuple[dict[str, str], str]:
    parents = {}
    for controller in (*REQUIRED, *OPTIONAL):
        path = next((p for names, p in cgroups.items() if controller in names.split(",")), None)
        for fstype, root, point, options in mounts:
            if fstype == "cgroup" and controller in options and path is not None:
                folder = _inside(root, point, path)
                if folder and os.path.isdir(folder) and _can_make_folders(folder):
                    parents[controller] = folder
                    break
    missing = [c for c in REQUIRED if c not in parents]
    return parents, (f"no writable cgroup v1 hierarchy for {', '.join(missing)}" if missing else "")


def _delegate(folder: str, wanted: tuple[str, ...]) -> set[str]:
    """Enable ``wanted`` controllers for the children of cgroup v2 ``folder``; those that are enabled."""
    for controller in wanted:
        with contextlib.suppress(OSError):
            _write(os.path.join(folder, "cgroup.subtree_control"), f"+{controller}")
    return set((_read(os.path.join(folder, "cgroup.subtree_control")) or "").split())


def _v2(mounts, path: str | None) -> tuple[dict[str, str], str]:
    if path is None:
        return {}, "no cgroup v2 entry in /proc/self/cgroup"
    for fstype, root, point, _ in mounts:
        folder = _inside(root, point, path) if fstype == "cgroup2" else None
        if folder is None or not os.path.isdir(folder):
            continue
        if os.path.basename(folder) == _TRUSTED:  # a grading process whose parent moved it here (see below)
            folder = os.path.dirname(folder)
        available = set((_read(os.path.join(folder, "cgroup.controllers")) or "").split())
        wanted = tuple(c for c in (*REQUIRED, "cpu") if c in available)
        if not set(REQUIRED) <= available:
            return {}, f"cgroup v2 at {folder} does not offer {', '.join(c for c in REQUIRED if c not in available)}"
        enabled = _delegate(folder, wanted)
        if not set(REQUIRED) <= enabled and _only_member(folder):
            # cgroup v2 lets only a cgroup without processes hand controllers to its children: when the grader
            # is alone in its cgroup (e.g. `systemd-run --scope`), it moves itself into a leaf of its own
            leaf = os.path.join(folder, _TRUSTED)
            with contextlib.suppress(OSError):
                os.makedirs(leaf, exist_ok=True)
                _write(os.path.join(leaf, "cgroup.procs"), os.getpid())
                enabled = _delegate(folder, wanted)
        if not set(REQUIRED) <= enabled or not _can_make_folders(folder):
            return {}, (f"cannot delegate memory and pids in cgroup v2 {folder} (it holds other processes, or is "
                        "not writable): run the grader as root in a cgroup of its own")
        return {c: folder for c in wanted if c in enabled}, ""
    return {}, "cgroup v2 is not mounted"


def _only_member(folder: str) -> bool:
    return (_read(os.path.join(folder, "cgroup.procs")) or "").split() == [str(os.getpid())]


def _sweep(parents: dict[str, str]) -> None:
    """Remove the workers' cgroups of graders that are no longer running (killed, or a machine that went down)."""
    for parent in dict.fromkeys(parents.values()):
        try:
            names = os.listdir(parent)
        except OSError:
            continue
        for name in names:
            found = _WORKER.match(name)
            if found and _start_time(int(found.group(1))) != int(found.group(2)):
                folder = os.path.join(parent, name)
                _remove_folder(folder, group=WorkerCgroup(1, {"any": folder}))
            elif name == _TRUSTED:
                with contextlib.suppress(OSError):  # only when no grader is left in it
                    os.rmdir(os.path.join(parent, name))


@functools.lru_cache(maxsize=1)
def detect() -> Cgroups:
    """The cgroups this process may make for its workers (cached); removes stale ones of dead graders first."""
    if os.getuid() != 0:
        return Cgroups(None, problem="only root may make cgroups for the workers")
    try:
        with open("/proc/self/mountinfo", encoding="utf-8", errors="replace") as f:
            mounts = _mounts(f.read())
        with open("/proc/self/cgroup", encoding="utf-8", errors="replace") as f:
            cgroups = dict(line.split(":", 2)[1:] for line in f.read().splitlines() if line.count(":") >= 2)
    except OSError as error:
        return Cgroups(None, problem=f"cannot read this process's cgroups: {error}")
    v1_memory = any(fstype == "cgroup" and "memory" in options for fstype, _, _, options in mounts)
    if v1_memory:
        parents, problem = _v1(mounts, {k: v for k, v in cgroups.items() if k})
        version = 1
    else:
        parents, problem = _v2(mounts, cgroups.get(""))
        version = 2
    if problem:
        return Cgroups(None, problem=problem)
    _sweep(parents)
    return Cgroups(version, parents)
