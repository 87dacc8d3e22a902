"""The sandbox, probed from inside: what student code in the grader's worker can and cannot reach.

Each test loads a ``probe()`` function into a fresh worker (:class:`labkit.grading.sandbox.Worker`)
and calls it: the probe tries what a cheating or careless submission would (import labkit, read
the course, write the gradebook, reach the network, kill its parent, fork or allocate without
end) and returns what happened, as plain data. Where a guard could be doubted, a control shows
that the same probe succeeds without it (scikit-learn imports when it is not masked; labkit
imports in the unsandboxed mode).
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
import time

import pytest

from labkit.grading import cgroups, sandbox
from labkit.grading.sandbox import CallTimedOut, Limits, Sandbox, Session, Worker, WorkerCrashed, worker_uid
from tests.grading_course import EXERCISES, REPO

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="the sandbox is Linux namespaces")
SLOT = 30  # uids worker_uid(30..33): used by no other test, so "no process of this uid is left" is exact


def probe(code: str, *args, slot: int = SLOT, **options):
    """Load ``code`` (which defines ``probe``) into a fresh worker, call ``probe(*args)``, kill the worker."""
    worker = Worker(Sandbox(slot=slot, **options))
    try:
        errors = worker.load([textwrap.dedent(code)], time.monotonic() + 60)
        assert errors == [], errors
        return worker.call("probe", args, {}, time.monotonic() + 60)
    finally:
        worker.kill()


def processes_of(uid: int) -> list[str]:
    listing = subprocess.run(["ps", "-e", "-o", "uid=,pid=,args="], capture_output=True, text=True).stdout
    return [line for line in listing.splitlines() if line.split()[0] == str(uid)]


def left_after(uid: int, seconds: float = 10.0) -> list[str]:
    """The processes of ``uid`` still there after up to ``seconds`` (the kernel empties a pid namespace
    soon after its init dies, but not at once)."""
    deadline = time.monotonic() + seconds
    while processes_of(uid) and time.monotonic() < deadline:
        time.sleep(0.1)
    return processes_of(uid)


# ---------------------------------------------------------------------------- who the student is
def test_student_code_runs_unprivileged():
    uid, gid, groups, status = probe("""
        import os
        def probe():
            return os.getresuid(), os.getresgid(), os.getgroups(), open("/proc/self/status").read()
    """)
    expected = worker_uid(SLOT)
    assert uid == (expected, expected, expected) and gid == (65534, 65534, 65534) and groups == []
    fields = dict(line.split(":\t", 1) for line in status.splitlines() if ":\t" in line)
    assert int(fields["CapEff"], 16) == 0 and int(fields["CapPrm"], 16) == 0
    assert fields["NoNewPrivs"].strip() == "1"


def test_the_environment_is_scrubbed():
    environment = probe("""
        import os
        def probe():
            return dict(os.environ)
    """)
    assert environment.pop("PWD", "/tmp") == "/tmp"  # bwrap's --chdir sets it
    assert set(environment) <= set(sandbox._ENVIRONMENT), environment
    assert environment["HOME"] == "/tmp" and environment["MPLBACKEND"] == "Agg"


def test_proc_shows_the_sandbox_only():
    pids, environ = probe("""
        import os
        def probe():
            try:
                open("/proc/1/environ").read()
                environ = "readable"
            except OSError as error:
                environ = type(error).__name__
            return sorted(int(p) for p in os.listdir("/proc") if p.isdigit()), environ
    """)
    assert pids == [1, 2], pids  # bwrap's init and the worker, nothing of the host
    assert environ == "PermissionError"


# ---------------------------------------------------------------------------- what the student cannot reach
def test_labkit_cannot_be_imported_by_any_road():
    tries = probe("""
        import importlib.util, site, sys
        import labkit as unused  # a top-level import in a cell binds a stub: an unused import costs nothing ...
        def probe(repo):
            found = {}
            try:
                unused.segment_labels  # ... but nothing comes out of it
                found["stub"] = "imported"
            except ImportError as error:
                found["stub"] = str(error)
            try:
                import labkit  # elsewhere (here: in a function, or in a try) the import itself fails
                found["import"] = "imported"
            except ImportError as error:
                found["import"] = str(error)
            for folder in [repo, *sys.path]:
                site.addsitedir(folder)
            sys.meta_path[:] = [f for f in sys.meta_path if type(f).__name__ != "_Unavailable"]
            try:
                import labkit
                found["without the message"] = "imported"
            except ImportError as error:
                found["without the message"] = type(error).__name__
            try:
                spec = importlib.util.spec_from_file_location("labkit", repo + "/labkit/__init__.py")
                spec.loader.exec_module(importlib.util.module_from_spec(spec))
                found["by path"] = "imported"
            except Exception as error:
                found["by path"] = type(error).__name__
            return found
    """, str(REPO))
    assert "labkit is not available when your notebook is graded (labkit.segment_labels)" in tries["stub"]
    assert "labkit is not available when your notebook is graded (labkit)" in tries["import"]
    assert tries["without the message"] in ("ModuleNotFoundError", "ImportError"), tries
    assert tries["by path"] == "FileNotFoundError", tries


def test_masked_packages_are_gone_and_the_others_import():
    code = """
        def probe():
            try:
                from sklearn.cluster import DBSCAN
                return "imported"
            except ImportError as error:
                return str(error)
    """
    assert "sklearn is not available" in probe(code, masked=("sklearn",))
    assert probe(code) == "imported"  # the control: scikit-learn is there when the exercise does not mask it


def test_the_course_and_the_machine_are_out_of_reach(tmp_path):
    other = tmp_path / "submitted" / "alice" / "ex01" / "ex01.ipynb"
    other.parent.mkdir(parents=True)
    other.write_text("{}")
    seen = probe("""
        import os
        def probe(paths):
            return {path: os.path.exists(path) for path in paths}, sorted(os.listdir("/"))
    """, [str(REPO), str(EXERCISES / "source"), str(EXERCISES / "grading"), str(EXERCISES / "gradebook.db"),
          str(other), str(tmp_path), "/etc/passwd", "/etc/shadow", "/home", "/work", "/usr/bin", "/bin/sh"])
    reachable, top = seen
    assert not any(reachable.values()), reachable
    assert set(top) <= {"bin", "dev", "etc", "grader", "lib", "lib32", "lib64", "opt", "proc", "root", "tmp",
                        "usr"}, top


def test_nothing_outside_tmp_can_be_written():
    results = probe("""
        import os, sys
        def probe():
            results = {}
            for path in ["/opt/site0/planted.py", "/grader/worker.py", sys.prefix + "/planted", "/tmp/ok"]:
                try:
                    with open(path, "w") as f:
                        f.write("x")
                    results[path] = "written"
                except OSError as error:
                    results[path] = type(error).__name__
            return results
    """)
    assert results.pop("/tmp/ok") == "written"
    assert all(outcome != "written" for outcome in results.values()), results


def test_there_is_no_network():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    server.settimeout(0.5)
    try:
        tries = probe("""
            import socket
            def probe(port):
                tries = {}
                for host, target in [("grader", port), ("internet", 53)]:
                    address = "127.0.0.1" if host == "grader" else "1.1.1.1"
                    try:
                        socket.create_connection((address, target), timeout=2).close()
                        tries[host] = "connected"
                    except OSError as error:
                        tries[host] = type(error).__name__
                try:
                    socket.getaddrinfo("pypi.org", 443)
                    tries["dns"] = "resolved"
                except OSError as error:
                    tries["dns"] = type(error).__name__
                return tries
        """, server.getsockname()[1])
        with pytest.raises(TimeoutError):
            server.accept()  # nothing from the sandbox ever knocked
    finally:
        server.close()
    assert "connected" not in tries.values() and tries["dns"] != "resolved", tries


# ---------------------------------------------------------------------------- what the student cannot break
def test_killing_the_parent_does_nothing():
    worker = Worker(Sandbox(slot=SLOT))
    try:
        worker.load([textwrap.dedent("""
            import os, signal
            def probe():
                outcome = {}
                for name, target in [("parent", os.getppid()), ("init", 1), ("everyone", -1)]:
                    try:
                        os.kill(target, signal.SIGKILL)
                        outcome[name] = "sent"
                    except OSError as error:
                        outcome[name] = type(error).__name__
                return outcome
            def alive():
                return "still here"
        """)], time.monotonic() + 60)
        outcome = worker.call("probe", (), {}, time.monotonic() + 60)
        assert outcome["parent"] == outcome["init"] == "PermissionError", outcome  # both are bwrap's root processes
        assert worker.call("alive", (), {}, time.monotonic() + 60) == "still here"
    finally:
        worker.kill()


def test_a_fork_bomb_stops_at_the_process_limit():
    uid = worker_uid(SLOT + 1)
    forks = probe("""
        import os, time
        def probe():
            count = 0
            while count < 10_000:
                try:
                    if os.fork() == 0:
                        while True:
                            time.sleep(1)
                except OSError:
                    return count
                count += 1
            return count
    """, slot=SLOT + 1)
    assert 0 < forks < Limits().processes
    assert left_after(uid) == [], "the fork bomb's processes outlived the sandbox"


def test_memory_and_disk_are_capped():
    outcome = probe("""
        def probe():
            outcome = {}
            try:
                blob = bytearray(8 * 2**30)
                outcome["memory"] = len(blob)
            except MemoryError:
                outcome["memory"] = "MemoryError"
            try:
                with open("/tmp/big", "wb") as f:
                    for _ in range(400):
                        f.write(b"x" * 2**20)
                outcome["disk"] = "written"
            except OSError as error:
                outcome["disk"] = type(error).__name__
            return outcome
    """)
    assert outcome == {"memory": "MemoryError", "disk": "OSError"}, outcome


def test_a_call_past_its_time_kills_the_whole_sandbox():
    uid = worker_uid(SLOT + 2)
    code = """
        import os
        def spin():
            for _ in range(5):
                if os.fork() == 0:
                    while True:
                        pass
            while True:
                pass
    """
    with Session(Sandbox(slot=SLOT + 2), [textwrap.dedent(code)], load_timeout_s=30, call_timeout_s=1.0) as session:
        session.begin_test(60)
        with pytest.raises(CallTimedOut, match="did not return within 1 s"):
            session.call("spin", (), {})
        assert session.timed_out and session.worker is None
    assert left_after(uid) == []


def test_the_sandbox_dies_with_the_grader():
    """A stand-in grader starts a worker whose student code leaves a sleeping child, then is killed."""
    uid = worker_uid(SLOT + 3)
    script = textwrap.dedent(f"""
        import time
        from labkit.grading.sandbox import Sandbox, Worker
        worker = Worker(Sandbox(slot={SLOT + 3}))
        worker.load(["import os, time\\nif os.fork() == 0:\\n    time.sleep(600)"], time.monotonic() + 60)
        print("ready", flush=True)
        time.sleep(600)
    """)
    grader = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert grader.stdout.readline().strip() == "ready"
        assert processes_of(uid), "the student's processes should be running"
        grader.send_signal(signal.SIGKILL)
        grader.wait()
        assert left_after(uid) == []
    finally:
        grader.kill()
        grader.wait()
        grader.stdout.close()


# ---------------------------------------------------------------------------- the channel
@pytest.mark.parametrize(("forged", "match"), [
    ("b'\\x40\\x00\\x00\\x00'", "larger than"),  # announces a 1 GB frame
    ("b'\\x00\\x00\\x00\\x05hello'", "not JSON"),
    ("struct.pack('>I', 17) + b'{\"id\": 99, \"value\": 1}'[:17]", "not JSON|protocol"),
])
def test_forged_frames_end_the_worker_not_the_grader(forged, match):
    worker = Worker(Sandbox(slot=SLOT))
    try:
        worker.load([textwrap.dedent(f"""
            import os, struct
            def probe():
                for fd in range(3, 20):
                    try:
                        os.write(fd, {forged})
                    except OSError:
                        pass
                return 1
        """)], time.monotonic() + 60)
        with pytest.raises(WorkerCrashed, match=match):
            worker.call("probe", (), {}, time.monotonic() + 60)
    finally:
        worker.kill()


def test_students_who_plot_still_can():
    size = probe("""
        import os
        import matplotlib.pyplot as plt
        def probe():
            plt.plot([0, 1], [1, 0])
            plt.savefig("/tmp/plot.png")
            return os.path.getsize("/tmp/plot.png")
    """)
    assert size > 1000


# ---------------------------------------------------------------------------- other modes
def test_bwrap_missing_is_refused_with_how_to_install_it(monkeypatch):
    monkeypatch.setattr(sandbox.shutil, "which", lambda name: None)
    with pytest.raises(FileNotFoundError, match=r"apt-get install bubblewrap.*--no-sandbox"):
        Sandbox()


def test_the_user_namespace_mode_runs_and_masks_too():
    """The mode for graders who are not root: bwrap maps uid 65534 in a user namespace."""
    uid, error = probe("""
        import os
        def probe():
            try:
                from labkit import segment_labels
                return os.getuid(), "imported"
            except ImportError as error:
                return os.getuid(), type(error).__name__
    """, user_namespace=True)
    assert (uid, error) == (65534, "ModuleNotFoundError")


def test_without_the_sandbox_nothing_is_isolated():
    """``--no-sandbox`` keeps the limits, but labkit and your files are reachable."""
    found = probe("""
        import os, sys
        def probe(repo):
            try:
                from labkit import segment_labels
                first = "imported"
            except ImportError as error:
                first = str(error)
            sys.meta_path[:] = [f for f in sys.meta_path if type(f).__name__ != "_Unavailable"]
            import site
            for folder in list(sys.path):
                site.addsitedir(folder)  # runs labkit's editable-install finder
            import labkit
            return first, labkit.__name__, os.path.exists(repo), os.getuid()
    """, str(REPO), isolate=False)
    message, imported, sees_repository, uid = found
    assert "not available when your notebook is graded" in message  # only a message ...
    assert imported == "labkit" and sees_repository  # ... which a student can remove
    # it drops root only where the runtime is readable by others (here it lives under /root, mode 700)
    assert uid in (worker_uid(SLOT), os.getuid())


def test_seccomp_refuses_what_crosses_submissions_or_escapes_limits():
    """Keyrings outlive the sandbox (a channel to the next submission on the same uid), memfd pages and
    SysV shared memory escape RLIMIT_AS, new namespaces widen the kernel's attack surface, a wider CPU
    affinity would take a neighbour's CPU: refused. Threads, fork and a process pool (with its /dev/shm
    semaphores) still work."""
    outcome = probe("""
        import ctypes, multiprocessing, os, threading
        def probe():
            libc = ctypes.CDLL(None, use_errno=True)
            outcome = {}
            for name, number, args in [("add_key", 248, (b"user", b"k", b"v", 1, -4)), ("keyctl", 250, (0, -4, 0)),
                                       ("unshare", 272, (0x10000000,)), ("clone newuser", 56, (0x10000000 | 17, 0)),
                                       ("shmget", 29, (0x1AB5EC, 65536, 0o1666)),
                                       ("sched_setaffinity", 203, (0, 0, 0))]:
                result = libc.syscall(number, *args)
                outcome[name] = os.strerror(ctypes.get_errno()) if result < 0 else "allowed"
            try:
                os.memfd_create("held")
                outcome["memfd_create"] = "allowed"
            except OSError as error:
                outcome["memfd_create"] = error.strerror
            worker = threading.Thread(target=lambda: None)
            worker.start()
            worker.join()
            with multiprocessing.get_context("fork").Pool(2) as pool:
                outcome["pool"] = pool.map(abs, [-1, -2])
            return outcome
    """)
    assert outcome.pop("pool") == [1, 2]
    assert set(outcome.values()) == {"Operation not permitted"}, outcome


def test_a_hostile_reply_costs_the_trusted_side_little_memory():
    """A frame of millions of empty objects is refused before it is parsed (see protocol.MAX_CONTAINERS)."""
    import resource

    worker = Worker(Sandbox(slot=SLOT))
    try:
        worker.load([textwrap.dedent("""
            import os, struct
            def probe():
                body = b'{"id":1,"value":[' + b"{}," * ((15 << 20) // 3) + b'{}]}'
                for fd in range(3, 40):
                    try:
                        os.write(fd, struct.pack(">I", len(body)) + body)
                    except OSError:
                        pass
                os._exit(0)
        """)], time.monotonic() + 60)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        with pytest.raises(WorkerCrashed, match="lists and objects"):
            worker.call("probe", (), {}, time.monotonic() + 60)
        grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    finally:
        worker.kill()
    assert grown_mb < 100, f"the trusted process grew by {grown_mb:.0f} MB"


# ---------------------------------------------------------------------------- cgroups: the sandbox as a whole
GROUPED = cgroups.detect()
needs_cgroups = pytest.mark.skipif(not GROUPED.usable, reason=f"no cgroups for the workers here: {GROUPED.problem}")


@needs_cgroups
def test_every_process_of_a_sandbox_is_in_its_cgroup_with_the_sandbox_limits():
    """A worker and the children it forks (each in a session of its own) are in one cgroup, which holds the
    memory, process and CPU limits of the whole sandbox; it is gone once the worker is."""
    limits = Limits(memory_bytes=512 << 20, processes=20, cpus=1)
    worker = Worker(Sandbox(slot=SLOT, limits=limits))
    try:
        worker.load([textwrap.dedent("""
            import os, time
            def probe():
                for _ in range(3):
                    if os.fork() == 0:
                        os.setsid()
                        time.sleep(600)
                return os.getpid()
        """)], time.monotonic() + 60)
        worker.call("probe", (), {}, time.monotonic() + 60)
        group = worker.cgroup
        members = group.pids()
        assert worker.process.pid in members and len(members) >= 6  # bwrap, its init, the worker, 3 children

        def read(controller: str, name: str) -> list[str]:
            with open(os.path.join(group.folders[controller], name)) as f:
                return f.read().split()

        if group.version == 1:
            assert read("memory", "memory.limit_in_bytes") == [str(512 << 20)]
            assert read("pids", "pids.max") == ["20"]
            if "cpu" in group.folders:
                assert int(read("cpu", "cpu.cfs_quota_us")[0]) == int(read("cpu", "cpu.cfs_period_us")[0])
        else:
            assert read("memory", "memory.max") == [str(512 << 20)] and read("pids", "pids.max") == ["20"]
            if "cpu" in group.folders:
                quota, period = read("cpu", "cpu.max")
                assert quota == period
        folders = list(group.folders.values())
    finally:
        worker.kill()
    assert not [folder for folder in folders if os.path.exists(folder)], "the worker's cgroup was left behind"


@needs_cgroups
def test_a_worker_killed_at_the_sandbox_memory_limit_is_that_calls_crash():
    """Children each within RLIMIT_AS, together over the cgroup's limit: the kernel kills the largest process
    of *that* sandbox (here the worker), the call ends as a crash that says why, the next test gets a fresh
    worker. (Without the cgroup the same code holds 6 x 128 MB: tests/test_grading_redteam.py.)"""
    code = """
        import os, time
        def hold():
            if os.fork() == 0:
                blob = bytearray(150 << 20)
                time.sleep(600)
            time.sleep(0.5)
            blob = bytearray(250 << 20)
            return len(blob)
        def fine():
            return 1
    """
    limits = Limits(memory_bytes=384 << 20)
    with Session(Sandbox(slot=SLOT, limits=limits), [textwrap.dedent(code)], load_timeout_s=30,
                 call_timeout_s=30) as session:
        session.begin_test(60)
        with pytest.raises(WorkerCrashed, match="memory limit"):
            session.call("hold", (), {})
        assert session.crashed and not session.timed_out
        session.begin_test(60)
        assert session.call("fine", (), {}) == 1


def test_without_cgroups_fewer_processes_and_a_cpu_of_its_own():
    """The fallback: RLIMIT_NPROC at UNGROUPED_PROCESSES (each process may hold the whole address-space limit,
    so fewer of them), and the job's CPU, which the student cannot widen."""
    uid = worker_uid(SLOT + 1)
    job = Sandbox(slot=SLOT + 1, cgroups=False)
    assert job.cgroups is None and job.cpu is not None
    outcome = probe("""
        import os, time
        def probe():
            outcome = {"cpus": sorted(os.sched_getaffinity(0))}
            try:
                os.sched_setaffinity(0, range(os.cpu_count()))
                outcome["widened"] = sorted(os.sched_getaffinity(0))
            except OSError as error:
                outcome["widened"] = error.strerror
            count = 0
            while count < 100:
                try:
                    if os.fork() == 0:
                        time.sleep(600)
                except OSError:
                    break
                count += 1
            outcome["forks"] = count
            return outcome
    """, slot=SLOT + 1, cgroups=False)
    assert outcome["cpus"] == [job.cpu]
    assert outcome["widened"] == "Operation not permitted"
    assert 0 < outcome["forks"] < sandbox.UNGROUPED_PROCESSES
    assert left_after(uid) == []


@needs_cgroups
def test_the_cgroups_of_a_grader_that_died_are_removed_at_the_next_start():
    """A cgroup named after a process that no longer runs (a grader killed with SIGKILL) is emptied and
    removed by the next detect(); one of a running grader is left alone."""
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead_pid = int(gone.stdout)
    parent = GROUPED.parents["pids"]
    stale = os.path.join(parent, f"{cgroups.PREFIX}{dead_pid}-1-w1")
    ours = cgroups.Cgroups(GROUPED.version, GROUPED.parents).create(64 << 20, 4, 1)
    os.mkdir(stale)
    sleeper = subprocess.Popen(["sleep", "600"])  # a process left behind in the dead grader's cgroup
    try:
        with open(os.path.join(stale, "cgroup.procs"), "w") as f:
            f.write(str(sleeper.pid))
        cgroups.detect.cache_clear()
        cgroups.detect()
        assert sleeper.wait(timeout=10) == -signal.SIGKILL
        assert not os.path.exists(stale)
        assert all(os.path.isdir(folder) for folder in ours.folders.values())
    finally:
        sleeper.kill()
        sleeper.wait()
        ours.remove()
        if os.path.exists(stale):
            os.rmdir(stale)


def test_cgroup_v2_files_and_mounts_are_read_and_written_as_the_kernel_has_them(tmp_path):
    """cgroup v2 cannot run beside this machine's v1 controllers; its files are checked on a stand-in folder."""
    folder = tmp_path / "w1"
    folder.mkdir()
    for name in ("memory.max", "memory.swap.max", "pids.max", "cpu.max"):
        (folder / name).write_text("max\n")
    (folder / "cpu.stat").write_text("usage_usec 2500000\nuser_usec 2000000\n")
    (folder / "memory.events").write_text("low 0\nhigh 0\nmax 3\noom 1\noom_kill 1\n")
    group = cgroups.WorkerCgroup(2, {c: str(folder) for c in ("memory", "pids", "cpu")})
    group.limit(256 << 20, 16, 1)
    assert [(folder / n).read_text().strip() for n in ("memory.max", "memory.swap.max", "pids.max", "cpu.max")] == [
        str(256 << 20), "0", "16", "100000 100000"]
    assert group.cpu_seconds() == 2.5 and group.oom_kills() == 1
    assert group.procs_files == [str(folder / "cgroup.procs")]
    mounts = cgroups._mounts("41 31 0:38 /grading /sys/fs/cgroup rw,relatime - cgroup2 cgroup2 rw,nsdelegate\n"
                             "35 31 0:32 / /sys/fs/cgroup/memory rw,relatime - cgroup cgroup rw,memory\n")
    assert mounts[0][:3] == ("cgroup2", "/grading", "/sys/fs/cgroup") and "memory" in mounts[1][3]
    assert cgroups._inside("/grading", "/sys/fs/cgroup", "/grading/job/x") == "/sys/fs/cgroup/job/x"
    assert cgroups._inside("/grading", "/sys/fs/cgroup", "/other") is None


def test_a_cell_is_interrupted_even_when_the_grader_runs_with_sigint_ignored():
    """``labkit grade all &`` in a script starts the grader with SIGINT ignored, and an ignored signal stays
    ignored across exec: the worker must still turn SIGINT into a KeyboardInterrupt in the running cell."""
    import threading

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        worker = Worker(Sandbox(slot=SLOT))
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        timer = threading.Timer(1.0, worker.interrupt)
        timer.start()
        errors = worker.load(["while True:\n    pass", "def after():\n    return 1"], time.monotonic() + 30)
        timer.join()
        assert [(e["cell"], e["message"]) for e in errors] == [(0, "KeyboardInterrupt: ")], errors
        assert worker.call("after", (), {}, time.monotonic() + 10) == 1  # the next cell still ran
    finally:
        worker.kill()
