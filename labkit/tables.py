"""Features as a table: one row per feature, for pandas and Parquet.

:func:`features_table` turns the :class:`labkit.Features` of a recording into a pandas
``DataFrame``; :func:`write_features_table` streams them into a Parquet file (``labkit extract
-o run.parquet``), a few thousand scans at a time, so memory stays flat however long the
recording. Both have the same columns (:data:`COLUMNS`):

===========================  ==============================================================
column                       meaning
===========================  ==============================================================
``recording``, ``method``    the file's name and the line extractor (only when given)
``scan``, ``stamp_ns``       the scan's place in the recording (0, 1, ...) and its stamp (ns)
``kind``                     ``line``, ``corner``, ``circle``, ``arc-like``, ``arc``, ``leg``, ``person``
``index``                    the feature's place among its scan's features of its layer
``first``, ``last``          its first and last beam (null for a person)
``n_points``                 points fitted (null for corners and people)
``x``, ``y``                 sensor frame, m: a line's midpoint, a corner, a circle's, leg's or person's centre
``x0, y0, x1, y1``           a line's end points (sensor frame, m)
``r``, ``alpha``             a line in normal form (m, rad)
``var_r, var_alpha,``        the line's (r, alpha) covariance (m², rad², m·rad)
``cov_r_alpha``
``length``, ``error``        a line's length and RMS fit error (m)
``radius``                   a circle's or arc's radius (m); ``diameter`` a leg's (m)
``angle``, ``corner_kind``,  a corner's angle (rad), ``convex``/``concave``, and whether it was
``extrapolated``             extrapolated
``iav_mean, iav_std``        inscribed-angle statistics (rad); ``confidence`` in [0, 1]
``pose_x, pose_y,``          the sensor's pose in the world frame (m, m, rad) when the scan has
``pose_theta``               one (:attr:`labkit.Scan.pose`), else null (NaN)
``world_*``                  ``x, y, x0, y0, x1, y1, r, alpha`` in the world frame (NaN without a pose)
===========================  ==============================================================

A column that does not apply to a kind is NaN (floats) or null. Scans with no features have no
rows (``df.groupby("scan").size().reindex(range(n_scans), fill_value=0)`` counts them as 0).
Stage timings are not in the table: they differ from run to run, and the table does not (a
parallel run gives the same table as a serial one).

pandas and pyarrow are imported when a table is made, not with labkit (``pip install
'labkit[research]'``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from pathlib import Path

from ._safe import OutputKind, safe_output, starts_with
from .errors import RefusedError
from .features import Features
from .scan import Scan

__all__ = ["COLUMNS", "PARQUET_FILE", "features_table", "write_features_table", "feature_rows", "read_table"]

_F, _I, _S, _B = "float64", "int64", "string", "bool"
#: Every column after ``recording`` and ``method``, with its type.
COLUMNS: dict[str, str] = {
    "scan": _I, "stamp_ns": _I, "kind": _S, "index": _I, "first": _I, "last": _I, "n_points": _I,
    "x": _F, "y": _F, "x0": _F, "y0": _F, "x1": _F, "y1": _F, "r": _F, "alpha": _F,
    "var_r": _F, "var_alpha": _F, "cov_r_alpha": _F, "length": _F, "error": _F, "radius": _F, "diameter": _F,
    "angle": _F, "corner_kind": _S, "extrapolated": _B, "iav_mean": _F, "iav_std": _F, "confidence": _F,
    "pose_x": _F, "pose_y": _F, "pose_theta": _F, "world_x": _F, "world_y": _F, "world_x0": _F, "world_y0": _F,
    "world_x1": _F, "world_y1": _F, "world_r": _F, "world_alpha": _F,
}
_NAMES = tuple(COLUMNS)
_N = len(_NAMES)
_AT = {name: i for i, name in enumerate(_NAMES)}
_NAN = float("nan")

#: What :func:`write_features_table` writes (see labkit._safe): a Parquet file, told by its magic.
PARQUET_FILE = OutputKind("a Parquet table (.parquet)", (".parquet",), starts_with(b"PAR1"))


def research_module(module: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise RefusedError(f"feature tables need {module.split('.')[0]}: pip install 'labkit[research]'") from None


def _to_world(pose, x: float, y: float) -> tuple[float, float]:
    px, py, th = pose
    c, s = math.cos(th), math.sin(th)
    return px + c * x - s * y, py + s * x + c * y


def _normal_form(r: float, alpha: float) -> tuple[float, float]:
    """:func:`labkit.geometry.normalize_line` for one line, with plain floats (30x faster)."""
    if r < 0:
        r, alpha = -r, alpha + math.pi
    alpha = math.remainder(alpha, 2 * math.pi)  # in [-pi, pi]
    if alpha <= -math.pi:
        alpha = math.pi
    if r == 0 and abs(alpha) > math.pi / 2:
        alpha = alpha - math.pi if alpha > 0 else alpha + math.pi
    return r, (math.pi / 2 if r == 0 and math.isclose(alpha, -math.pi / 2) else alpha)


def feature_rows(scan_index: int, features: Features, pose=None) -> list[tuple]:
    """The rows of one scan's features, as tuples in :data:`COLUMNS` order.

    Parameters
    ----------
    scan_index : int
        The scan's number (the ``scan`` column).
    features : Features
        Its features.
    pose : tuple of (float, float, float) or None
        The sensor's pose ``(x, y, theta)`` in the world frame, for the pose and world-frame columns; None:
        those are NaN.

    Returns
    -------
    list of tuple
        One row per feature.
    """
    rows = []
    head = (scan_index, int(features.stamp_ns))
    world = pose is not None
    px, py, pt = pose if world else (_NAN, _NAN, _NAN)

    def row(kind: str, index: int, **values) -> None:
        out: list = [_NAN] * _N
        out[0], out[1], out[2], out[3] = head[0], head[1], kind, index
        for k in ("first", "last", "n_points", "corner_kind", "extrapolated"):
            out[_AT[k]] = None
        for k, v in values.items():
            out[_AT[k]] = v
        out[_AT["pose_x"]], out[_AT["pose_y"]], out[_AT["pose_theta"]] = px, py, pt
        if world:
            out[_AT["world_x"]], out[_AT["world_y"]] = _to_world(pose, values["x"], values["y"])
        rows.append(tuple(out))

    for i, ln in enumerate(features.lines):
        (x0, y0), (x1, y1) = (float(v) for v in ln.start), (float(v) for v in ln.end)
        cov = ln.covariance
        extra = {}
        if world:
            wx0, wy0 = _to_world(pose, x0, y0)
            wx1, wy1 = _to_world(pose, x1, y1)
            a = ln.alpha + pt
            wr, wa = _normal_form(ln.r + px * math.cos(a) + py * math.sin(a), a)
            extra = {"world_x0": wx0, "world_y0": wy0, "world_x1": wx1, "world_y1": wy1, "world_r": wr,
                     "world_alpha": wa}
        row("line", i, first=int(ln.first), last=int(ln.last), n_points=int(ln.n_points), x=(x0 + x1) / 2,
            y=(y0 + y1) / 2, x0=x0, y0=y0, x1=x1, y1=y1, r=float(ln.r), alpha=float(ln.alpha), var_r=float(cov[0, 0]),
            var_alpha=float(cov[1, 1]), cov_r_alpha=float(cov[0, 1]), length=ln.length, error=float(ln.error), **extra)
    for i, c in enumerate(features.corners):
        row("corner", i, first=int(c.first), last=int(c.last), x=float(c.point[0]), y=float(c.point[1]),
            angle=float(c.angle), corner_kind=c.kind, extrapolated=bool(c.extrapolated))
    for layer in ("circles", "arcs"):
        for i, c in enumerate(getattr(features, layer)):
            row(c.kind, i, first=int(c.first), last=int(c.last), n_points=int(c.n_points), x=float(c.center[0]),
                y=float(c.center[1]), radius=float(c.radius), iav_mean=float(c.iav_mean), iav_std=float(c.iav_std),
                confidence=float(c.confidence))
    for i, g in enumerate(features.legs):
        row("leg", i, first=int(g.first), last=int(g.last), n_points=int(g.n_points), x=float(g.center[0]),
            y=float(g.center[1]), diameter=float(g.diameter), iav_mean=float(g.iav_mean), iav_std=float(g.iav_std))
    for i, p in enumerate(features.people):
        row("person", i, x=float(p.center[0]), y=float(p.center[1]))
    return rows


def _schema(recording: bool, method: bool):
    pa = research_module("pyarrow")
    types = {_F: pa.float64(), _I: pa.int64(), _S: pa.string(), _B: pa.bool_()}
    head = [pa.field("recording", pa.string())] * recording + [pa.field("method", pa.string())] * method
    return pa.schema(head + [pa.field(name, types[t]) for name, t in COLUMNS.items()])


def _arrow(rows: list[tuple], schema, constants: tuple):
    pa = research_module("pyarrow")
    columns = list(zip(*rows, strict=True)) if rows else [()] * _N
    n = len(rows)
    arrays = [pa.array([value] * n, type=pa.string()) for value in constants]
    first = len(constants)
    for k, values in enumerate(columns):
        field = schema.field(first + k)
        arrays.append(pa.array(values, type=field.type, from_pandas=True))  # NaN and None: null
    return pa.Table.from_arrays(arrays, schema=schema)


def _pairs(features: Iterable[Features], scans: Iterable[Scan] | None) -> Iterator[tuple[Scan | None, Features]]:
    if scans is None:
        for f in features:
            yield None, f
        return
    for scan, f in zip(scans, features, strict=True):
        if scan.stamp_ns != f.stamp_ns:
            raise ValueError(f"scans and features disagree: scan stamp {scan.stamp_ns}, features stamp {f.stamp_ns}"
                             "; give one scan per Features, in the same order")
        yield scan, f


def features_table(features: Iterable[Features], scans: Iterable[Scan] | None = None, *,
                   recording: str | None = None, method: str | None = None):
    """One row per feature of ``features`` (columns: module docstring), as a pandas DataFrame.

    Parameters
    ----------
    features : iterable of Features
        One per scan, in order (e.g. :func:`labkit.extract_all`); row ``scan`` is its place.
    scans : iterable of Scan, optional
        The scans the features come from (same order): their poses give the world-frame
        columns. Without them, or for a scan without a pose, those columns are NaN.
    recording, method : str, optional
        Add a ``recording`` / ``method`` column holding this value (tables of many recordings
        or line extractors concatenate with ``pandas.concat``).

    Returns
    -------
    pandas.DataFrame
        Integer columns that can be missing (``first``, ``last``, ``n_points``) are pandas
        ``Int64``, ``extrapolated`` is ``boolean``, text columns are strings.

    Examples
    --------
    >>> import labkit
    >>> scans = list(labkit.read_scans(labkit.bundled_data("corridor.mcap")))[:20]
    >>> df = labkit.features_table(labkit.extract_all(scans), scans)
    >>> df.groupby("kind").size().loc["line"] > 20, df["world_x"].notna().all()
    (np.True_, np.True_)
    """
    rows: list[tuple] = []
    for k, (scan, f) in enumerate(_pairs(features, scans)):
        rows.extend(feature_rows(k, f, None if scan is None else scan.pose))
    constants = tuple(v for v in (recording, method) if v is not None)
    return _to_pandas(_arrow(rows, _schema(recording is not None, method is not None), constants))


def _to_pandas(table):
    pa, pd = research_module("pyarrow"), research_module("pandas")
    mapping = {pa.int64(): pd.Int64Dtype(), pa.bool_(): pd.BooleanDtype(), pa.string(): pd.StringDtype()}
    return table.to_pandas(types_mapper=mapping.get)


def write_features_table(pairs: Iterable[tuple[Scan, Features]], out: str | Path, *, recording: str | None = None,
                         method: str | None = None, overwrite: bool = False, inputs: Iterable[str | Path] = (),
                         chunk_scans: int = 2000, first_scan: int = 0) -> tuple[int, int]:
    """Stream ``(scan, features)`` pairs into a Parquet table.

    The rows are :func:`features_table`'s, written ``chunk_scans`` scans at a time (one row group
    each). The file is written under a temporary name, renamed when complete; if iterating
    ``pairs`` raises :class:`labkit.CorruptFileError` (a damaged recording) the table holds every
    scan before it and the error propagates; interrupted, what was written so far is a valid
    ``<name>.partial.parquet``.

    Parameters
    ----------
    pairs : iterable of tuple of (Scan, Features)
        The scans and their features, in order.
    out : str or Path
        The Parquet file.
    recording : str or None
        The value of a ``recording`` column in front of the others; None: no such column.
    method : str or None
        The value of a ``method`` column (the line extractor); None: no such column.
    overwrite : bool
        Replace an existing Parquet file (never any other kind of file).
    inputs : iterable of str or Path
        The files read, which the output may not be.
    chunk_scans : int
        Scans per row group.
    first_scan : int
        The ``scan`` column's number of the first pair (where the pairs start in the recording,
        e.g. a scan range's first scan).

    Returns
    -------
    scans : int
        The scans written.
    rows : int
        The rows written.
    """
    pq = research_module("pyarrow.parquet")
    schema = _schema(recording is not None, method is not None)
    constants = tuple(v for v in (recording, method) if v is not None)
    n_scans = n_rows = 0
    with safe_output(out, PARQUET_FILE, overwrite=overwrite, inputs=inputs) as tmp:
        writer = pq.ParquetWriter(tmp, schema)
        rows: list[tuple] = []
        try:
            for scan, f in pairs:
                rows.extend(feature_rows(first_scan + n_scans, f, scan.pose))
                n_scans += 1
                if n_scans % chunk_scans == 0:
                    writer.write_table(_arrow(rows, schema, constants))
                    n_rows, rows = n_rows + len(rows), []
        finally:  # a damaged or interrupted input: what was read is written and the file closed properly
            if rows or n_rows == 0:
                writer.write_table(_arrow(rows, schema, constants))
                n_rows += len(rows)
            writer.close()
    return n_scans, n_rows


def read_table(path: str | Path):
    """A Parquet feature table as a pandas DataFrame.

    A Parquet feature table (:func:`write_features_table`, ``labkit extract -o x.parquet``) as a
    pandas DataFrame with :func:`features_table`'s column types.

    Parameters
    ----------
    path : str or Path
        A Parquet feature table.

    Returns
    -------
    pandas.DataFrame
        One row per feature, with :func:`features_table`'s column types.
    """
    pq = research_module("pyarrow.parquet")
    return _to_pandas(pq.read_table(path))
