"""Writing outputs without losing anyone's data: the one mechanism every labkit writer uses.

The rules (README, "When things go wrong"):

1. **Temporary name, then rename.** An output is written as ``<name>`` inside a hidden folder
   beside the target, ``.<name>.labkit-XXXXXXXX/``, and renamed into place only when it is
   complete. A file replaces the old one atomically (``os.replace``); a bag folder is swapped
   in with two renames.
2. **Replace only what is ours.** An existing target is replaced only when asked
   (``overwrite=True``, ``-f``) *and* when it is recognised, from its contents, as the kind
   of output being written (a ROS1 bag by its magic bytes, a ROS2 bag folder by its
   ``metadata.yaml`` and nothing but bag files in it, ...). Any other file or folder is refused.
3. **Never the input.** The output may not be an input (same resolved path, or the same file
   under another name: ``os.path.samefile``), lie inside an input folder, or be a folder
   that holds an input.
4. **Folders.** Missing folders on the way to the output are created; if the write then fails,
   the ones created (and still empty) are removed again.
5. **When it goes wrong.** An exception marked ``keeps_output`` (a damaged input: the output
   already holds every readable record) still renames the output into place and propagates.
   ``KeyboardInterrupt``: the writer has closed the output with what it had; it is moved to
   ``<stem>.partial<suffix>`` beside the target (the target is unchanged) and
   :class:`OutputInterrupted` says where. Any other exception: the temporary output is
   removed, the target is unchanged.

Only the standard library is used, so every layer of labkit (the simulator's ground truth,
``Config.save``) can write through it.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from .errors import OutputExistsError, RefusedError

__all__ = ["OutputKind", "OutputInterrupted", "check_output", "safe_output", "starts_with", "json_object_with",
           "first_json_line_with"]

TEMP_MARK = ".labkit-"


@dataclass(frozen=True)
class OutputKind:
    """What a writer writes, and how to recognise one that already exists.

    Attributes
    ----------
    what : str
        A name for messages: ``"a ROS1 bag (.bag)"``.
    suffixes : tuple of str
        File name endings the output must have (lower case, e.g. ``(".rrd",)``); empty for a
        folder output, whose name may end in none of ``avoid``.
    recognise : callable (Path) -> bool
        True when an existing path is an output of this kind (and may be replaced with
        ``overwrite=True``). Must not raise for any file or folder.
    folder : bool
        The output is a folder (a ROS2 bag).
    avoid : tuple of str
        For folder outputs: endings that mean the user meant a file of another kind.
    """

    what: str
    suffixes: tuple[str, ...]
    recognise: Callable[[Path], bool]
    folder: bool = False
    avoid: tuple[str, ...] = ()

    def suffix_of(self, path: Path) -> str:
        name = path.name.lower()
        return next((s for s in self.suffixes if name.endswith(s)), "")


class OutputInterrupted(KeyboardInterrupt):
    """Raised instead of ``KeyboardInterrupt`` by :func:`safe_output`.

    Attributes
    ----------
    target : Path
        The output that was being written (unchanged).
    partial : Path or None
        Where the output written so far was kept, or None when nothing had been written.
    """

    def __init__(self, target: Path, partial: Path | None) -> None:
        super().__init__(f"interrupted while writing {target}")
        self.target = target
        self.partial = partial


# ---------------------------------------------------------------------------- recognisers
def starts_with(*magics: bytes) -> Callable[[Path], bool]:
    """A recogniser for files that begin with one of ``magics``."""

    def recognise(path: Path) -> bool:
        try:
            with open(path, "rb") as fh:
                head = fh.read(max(map(len, magics)))
        except OSError:
            return False
        return any(head.startswith(m) for m in magics)

    return recognise


def json_object_with(*keys: str, allowed: Iterable[str] | None = None) -> Callable[[Path], bool]:
    """A recogniser for a JSON file holding one object with all of ``keys`` (and, with
    ``allowed``, no other key)."""
    allowed = None if allowed is None else set(allowed)

    def recognise(path: Path) -> bool:
        try:
            obj = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return False
        return (isinstance(obj, dict) and all(k in obj for k in keys)
                and (allowed is None or set(obj) <= allowed))

    return recognise


def first_json_line_with(*keys: str) -> Callable[[Path], bool]:
    """A recogniser for JSON-lines files whose first line is an object with one of ``keys``
    (an empty file counts: replacing it loses nothing)."""

    def recognise(path: Path) -> bool:
        try:
            with open(path, encoding="utf-8") as fh:
                line = fh.readline(1 << 24)
        except (OSError, ValueError):
            return False
        if not line.strip():
            return path.stat().st_size == 0
        try:
            obj = json.loads(line)
        except ValueError:
            return False
        return isinstance(obj, dict) and any(k in obj for k in keys)

    return recognise


# ---------------------------------------------------------------------------- checks
def _is_within(inner: Path, outer: Path) -> bool:
    return inner == outer or outer in inner.parents


def _clash(target: Path, source: Path) -> str | None:
    """Why ``target`` may not be written when ``source`` is read, or None."""
    if not source.exists():
        return None
    t, s = target.resolve(), source.resolve()
    if t == s or (target.exists() and os.path.samefile(target, source)):
        return f"{target} is the input {source}: choose another output name"
    if s.is_dir() and _is_within(t, s):
        return f"{target} lies inside the input folder {source}: write it somewhere else"
    if target.is_dir() and _is_within(s, t):
        return f"the input {source} lies inside {target}: replacing it would delete the input"
    return None


def check_output(target: str | Path, kind: OutputKind, *, overwrite: bool = False,
                 inputs: Iterable[str | Path] = ()) -> Path:
    """Refuse, with a :class:`~labkit.errors.RefusedError`, an output that breaks the rules
    (module docstring); return it as a ``Path`` when it may be written.

    Called by :func:`safe_output` before anything is written; commands call it early too,
    before they start reading, so that a refusal costs nothing.
    """
    target = Path(target)
    if target.name in ("", ".", "..") or str(target) in (os.sep, "."):
        raise RefusedError(f"{target} is a folder, not an output name: write {kind.what} to a new name")
    if kind.suffixes and not kind.suffix_of(target):
        ends = " or ".join(kind.suffixes)
        raise RefusedError(f"{target}: {kind.what} must be named *{ends}")
    if kind.folder and target.name.lower().endswith(kind.avoid):
        raise RefusedError(f"{target}: {kind.what} is a folder; its name must not end in "
                           f"{target.suffix} (that names another format)")
    for source in inputs:
        problem = _clash(target, Path(source))
        if problem:
            raise RefusedError(problem)
    if target.exists() or target.is_symlink():
        if not overwrite:
            raise OutputExistsError(target)
        is_ours = target.is_dir() == kind.folder and not target.is_symlink() and kind.recognise(target)
        if not is_ours:
            sort = "folder" if target.is_dir() else "file"
            raise RefusedError(
                f"{target} exists and is not {kind.what}: labkit replaces only its own kind of output, "
                f"never another {sort}; choose another name",
                f"{target} exists and is not {kind.what}: -f replaces only {kind.what}, never another "
                f"{sort}; choose another name")
    return target


# ---------------------------------------------------------------------------- writing
def make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return the ones this call created, innermost first.
    Another writer may create the same folder at the same moment (parallel tasks writing into one new
    output folder): that folder is then theirs, not an error."""
    missing = []
    p = folder
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    created = []
    for p in reversed(missing):
        try:
            p.mkdir()
        except FileExistsError:
            if not p.is_dir():
                raise
            continue
        created.append(p)
    return created[::-1]


def remove_empty(folders: list[Path]) -> None:
    for p in folders:
        with contextlib.suppress(OSError):
            p.rmdir()


def partial_name(target: Path, kind: OutputKind) -> Path:
    suffix = kind.suffix_of(target)
    stem = target.name[: len(target.name) - len(suffix)] if suffix else target.name
    return target.with_name(f"{stem}.partial{target.name[len(stem):]}")


def _put_in_place(new: Path, target: Path, kind: OutputKind, scratch: Path) -> None:
    if kind.folder and target.exists():
        old = scratch / "replaced"
        os.rename(target, old)
        try:
            os.rename(new, target)
        except BaseException:
            os.rename(old, target)
            raise
    else:
        os.replace(new, target)


@contextlib.contextmanager
def safe_output(target: str | Path, kind: OutputKind, *, overwrite: bool = False,
                inputs: Iterable[str | Path] = ()) -> Iterator[Path]:
    """Give a writer a temporary path to write ``target`` to, then put it in place.

    Use it as ``with safe_output(path, KIND, overwrite=..., inputs=[src]) as tmp:`` and
    write (and close) the output at ``tmp`` inside the block. See the module docstring for
    what happens on success, on a damaged input, on interruption and on failure.
    """
    target = check_output(target, kind, overwrite=overwrite, inputs=inputs)
    created: list[Path] = []
    try:
        created = make_parents(target.parent)
        scratch = Path(tempfile.mkdtemp(prefix=f".{target.name}{TEMP_MARK}", dir=target.parent))
    except OSError as exc:
        remove_empty(created)
        raise type(exc)(exc.errno, f"{exc.strerror} (cannot write in {target.parent})", str(target)) from None
    tmp = scratch / target.name
    try:
        yield tmp
    except KeyboardInterrupt:
        partial = None
        if tmp.exists():
            candidate = partial_name(target, kind)
            if not candidate.exists() or (candidate.is_dir() == kind.folder and kind.recognise(candidate)):
                with contextlib.suppress(OSError):
                    _put_in_place(tmp, candidate, kind, scratch)
                    partial = candidate
        shutil.rmtree(scratch, ignore_errors=True)
        remove_empty(created if partial is None else [])
        raise OutputInterrupted(target, partial) from None
    except BaseException as exc:
        if getattr(exc, "keeps_output", False) and tmp.exists():
            _put_in_place(tmp, target, kind, scratch)
            shutil.rmtree(scratch, ignore_errors=True)
        else:
            shutil.rmtree(scratch, ignore_errors=True)
            remove_empty(created)
        if isinstance(exc, OSError) and exc.filename and TEMP_MARK in str(exc.filename):
            exc.filename = str(target)  # speak of the file the user asked for, not our temporary one
        raise
    if not tmp.exists():
        shutil.rmtree(scratch, ignore_errors=True)
        remove_empty(created)
        raise RuntimeError(f"the writer of {target} wrote nothing")  # a bug in labkit, not the user's
    try:
        _put_in_place(tmp, target, kind, scratch)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
