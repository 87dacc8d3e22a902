"""What labkit's compiled engines share (private: not part of labkit's API).

The engines (:mod:`labkit._segmentation_engine`, :mod:`labkit._noise_engine`,
:mod:`labkit.lines._split_merge_engine`) run the readable algorithms' exact arithmetic as
numba-compiled loops: the same IEEE operations in the same order, so that they give the same
features bit for bit. This module holds the pieces of that arithmetic that numpy or Python
compute in a way of their own:

* :func:`jit` -- ``numba.njit`` with the on-disk cache (a second process loads the machine code
  instead of compiling it again), IEEE division (``error_model="numpy"``: x / 0 is inf, not an
  exception) and no fast-math (no reassociation, no fused multiply-add);
* :func:`pairwise_sum` -- ``numpy.sum`` of a float64 array: numpy's pairwise summation
  (blocks of 128 summed with 8 accumulators, halves above that), which a plain loop does not
  reproduce;
* :func:`remainder_2pi` -- ``math.remainder(x, 2 pi)`` for the angles the algorithms wrap;
* :func:`line_from_sums` -- :func:`labkit.fitting.line_from_sums`, the closed-form weighted fit;
* :func:`dot2` and :data:`FUSED_DOT` -- a point projected on a direction as ``points @ (c, s)``
  computes it: numpy hands that to BLAS, whose kernel may fuse the multiply-add (OpenBLAS on an
  FMA processor computes ``fma(x, c, y s)``). :func:`blas_dot_rounding` finds out once, by exact
  arithmetic on a few numbers, which rounding this machine's BLAS uses; where it is neither, the
  engines are not used (:data:`FUSED_DOT` is None) and the readable code runs.

* :func:`py_hypot` -- :func:`math.hypot` as CPython computes it (its own algorithm, not the C
  library's ``hypot``, which numba calls and which differs in the last bit about once in 170 pairs);
  :func:`py_hypot_is_pythons` checks it once per process;
* :func:`monotonic_ns` -- the clock :func:`time.perf_counter` reads, for the stage times of a pass.

The other transcendental functions (``math.cos``, ``sin``, ``atan2``, ``pow``) are the C library's
in numba, in numpy's float64 loops and in Python alike; ``tests/test_engine.py`` checks that on
this machine.
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from fractions import Fraction

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["jit", "jit_inline", "fma", "pairwise_sum", "sum_at", "segment_sum", "remainder_2pi", "line_from_sums",
           "dot2", "monotonic_ns", "MONOTONIC_CLOCK", "py_hypot", "py_hypot_in_range",
           "py_hypot_is_pythons", "blas_dot_rounding", "FUSED_DOT", "PI", "TWO_PI", "HALF_PI"]

PI = math.pi
TWO_PI = 2 * math.pi
HALF_PI = math.pi / 2


def jit(fn):
    """``fn`` compiled by numba on its first call, cached on disk (see the module docstring).

    The cache is numba's: ``__pycache__`` beside the source when that folder is writable (an
    editable install: the repository's ``labkit/**/__pycache__``), else the user's cache folder
    (``~/.cache/numba``), or ``$NUMBA_CACHE_DIR`` when set. Where none is writable the engines
    still run, compiled afresh in every process (a warning says so once)."""
    try:
        return numba.njit(cache=True, nogil=True, error_model="numpy")(fn)
    except RuntimeError as exc:  # numba: "cannot cache function ...: no locator available"
        if "cannot cache" not in str(exc):
            raise
        _warn_no_cache(str(exc))
        return numba.njit(nogil=True, error_model="numpy")(fn)


def jit_inline(fn):
    """:func:`jit` for a small helper that LLVM inlines into its callers. (numba's own
    ``inline="always"`` copies the helper into each caller before typing: a fifth more
    compilation time for the engines, measured, and no faster code.)"""
    return jit(fn)


_WARNED: list[str] = []


def _warn_no_cache(reason: str) -> None:
    if not _WARNED:
        _WARNED.append(reason)
        warnings.warn(f"labkit's compiled engines find no writable cache folder ({reason}): every process "
                      "compiles them again on its first scan (some 30 s of CPU); set NUMBA_CACHE_DIR to a "
                      "writable folder", RuntimeWarning, stacklevel=3)


@jit
def segment_sum(a, lo, n):
    """A segment's sum as ``numpy.add.reduceat`` gives it: its first value plus numpy's pairwise
    sum of the others (``n >= 1`` values from ``a[lo]``)."""
    if n == 1:
        return a[lo]
    return a[lo] + _pairwise(a, lo + 1, n - 1)


@jit
def sum_at(a, lo, n):
    """``numpy.sum(a[lo:lo + n])`` bit for bit (see :func:`pairwise_sum`)."""
    return 0.0 + _pairwise(a, lo, n)


@jit
def pairwise_sum(a, n):
    """``numpy.sum(a[:n])`` bit for bit (float64, contiguous): ``0.0 +`` numpy's pairwise sum
    (:func:`_pairwise`)."""
    return 0.0 + _pairwise(a, n - n, n)


@jit
def _pairwise(a, lo, n):
    """numpy's pairwise sum of ``a[lo:lo + n]``: blocks of up to 128 values are summed by eight
    accumulators (:func:`_block`); a longer run is split in two, the first half a multiple of 8,
    and the halves' sums added. The recursion is unrolled onto a stack (numba cannot cache a
    recursive function)."""
    if n <= 128:
        return _block(a, lo, n)
    node_lo = np.empty(192, np.int64)
    node_n = np.empty(192, np.int64)
    node_split = np.zeros(192, np.bool_)
    sums = np.empty(96)
    n_sums = 0
    node_lo[0], node_n[0] = lo, n
    top = 1
    while top:
        top -= 1
        at, size = node_lo[top], node_n[top]
        if size <= 128:
            sums[n_sums] = _block(a, at, size)
            n_sums += 1
        elif node_split[top]:  # both halves summed: add them
            n_sums -= 1
            sums[n_sums - 1] = sums[n_sums - 1] + sums[n_sums]
        else:  # this node again once its halves are done, then the second half, then the first
            half = size // 2
            half -= half % 8
            node_split[top] = True
            node_lo[top + 1], node_n[top + 1], node_split[top + 1] = at + half, size - half, False
            node_lo[top + 2], node_n[top + 2], node_split[top + 2] = at, half, False
            top += 3
    return sums[0]


@jit_inline
def _block(a, lo, n):
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]  # eight accumulators, then the rest one by one
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    stop = n - n % 8
    while i < stop:
        j = lo + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@jit_inline
def remainder_2pi(x):
    """``math.remainder(x, 2 pi)`` for ``|x| < 3 pi``: the result is exact (Sterbenz), and a
    half-way ``x = +-pi`` stays (the quotient 0.5 rounds to the even 0)."""
    if x > PI:
        return x - TWO_PI
    if x < -PI:
        return x + TWO_PI
    return x


@jit_inline
def line_from_sums(sw, sx, sy, sxx, syy, sxy):
    """:func:`labkit.fitting.line_from_sums`, the same operations in the same order."""
    num = 2.0 * (sxy - sx * sy / sw)
    den = (sxx - syy) - (sx * sx - sy * sy) / sw
    alpha = 0.5 * math.atan2(num, den) + HALF_PI
    r = (sx * math.cos(alpha) + sy * math.sin(alpha)) / sw
    if r < 0:
        r = -r
        alpha = alpha + PI
    return r, remainder_2pi(alpha)


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.DoubleType(), [ir.DoubleType()] * 3),
                                            "llvm.fma.f64")
        return builder.call(fn, args)

    return sig, codegen


@intrinsic
def monotonic_ns(typingctx):
    """The clock :func:`time.perf_counter` reads on Linux (``clock_gettime(CLOCK_MONOTONIC)``), in
    nanoseconds: a compiled pass of several stages times each as Python would (the C library's
    function, found by name when the machine code is loaded, so a cached kernel keeps working)."""
    sig = types.int64()

    def codegen(context, builder, signature, args):
        i64, i32 = ir.IntType(64), ir.IntType(32)
        timespec = ir.LiteralStructType([i64, i64])
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(i32, [i32, timespec.as_pointer()]),
                                            "clock_gettime")
        ts = cgutils.alloca_once(builder, timespec)
        builder.call(fn, [ir.Constant(i32, _CLOCK_MONOTONIC), ts])
        sec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 0))
        nsec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 1))
        return builder.add(builder.mul(sec, ir.Constant(i64, 1_000_000_000)), nsec)

    return sig, codegen


_CLOCK_MONOTONIC = 1  # (Linux's clockid; monotonic_ns is used only where perf_counter reads it: MONOTONIC_CLOCK)

#: Whether :func:`monotonic_ns` reads :func:`time.perf_counter`'s clock here (Linux).
MONOTONIC_CLOCK = sys.platform.startswith("linux") and \
    time.get_clock_info("perf_counter").implementation == "clock_gettime(CLOCK_MONOTONIC)"


DBL_MIN = 2.2250738585072014e-308  # the least positive normal float


@jit_inline
def _two_product(x, y):
    """``x * y`` and its rounding error, exactly (a fused multiply-add)."""
    p = x * y
    return p, fma(x, y, -p)


@jit_inline
def py_hypot(x, y):
    """:func:`math.hypot` of two floats as CPython computes it (its ``vector_norm``: scaled by a power
    of two, the squares summed exactly, a differential correction of the square root), not the C
    library's ``hypot``, which numba calls and which differs in the last bit now and then. Proven
    on this Python by :func:`py_hypot_is_pythons` and ``tests/test_engine.py``; not for subnormal
    arguments (the callers hand those to Python: :func:`py_hypot_in_range`)."""
    ax, ay = abs(x), abs(y)
    if math.isinf(ax) or math.isinf(ay):
        return math.inf
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    top = ax if ax > ay else ay
    if top == 0.0:
        return top
    _, e = math.frexp(top)
    scale = math.ldexp(1.0, -e)
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for v in (ax, ay):
        u = v * scale
        hi, lo = _two_product(u, u)
        total = csum + hi
        frac2 += (csum - total) + hi
        csum = total
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _two_product(-h, h)
    total = csum + hi
    frac2 += (csum - total) + hi
    csum = total
    frac1 += lo
    h += (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)
    return h / scale


@jit_inline
def py_hypot_in_range(x, y):
    """Whether :func:`py_hypot` covers ``(x, y)``: not both subnormal (or one subnormal, one zero)."""
    return not (abs(x) < DBL_MIN and abs(y) < DBL_MIN and (x != 0.0 or y != 0.0))


@jit
def _py_hypots(x, y):
    out = np.empty(len(x))
    for i in range(len(x)):
        out[i] = py_hypot(x[i], y[i])
    return out


def py_hypot_is_pythons(n: int = 4000) -> bool:
    """Whether :func:`py_hypot` gives this Python's :func:`math.hypot` on ``n`` pairs of every scale a
    scan has (and zeros, infinities, NaN)."""
    rng = np.random.default_rng(20261129)
    x = rng.normal(size=n) * 10.0 ** rng.integers(-6, 4, n)
    y = rng.normal(size=n) * 10.0 ** rng.integers(-6, 4, n)
    x[:8] = [0.0, -0.0, 3.0, math.inf, math.nan, 1e300, 5.0, 0.0]
    y[:8] = [0.0, 2.0, 4.0, 1.0, 1.0, 1e300, -math.inf, 1e-300]
    got = _py_hypots(x, y).tolist()
    want = [math.hypot(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)]
    return all(g == w or (g != g and w != w) for g, w in zip(got, want, strict=True))


@jit_inline
def dot2(x, y, c, s, fused):
    """``x c + y s`` as ``numpy.dot`` of the point ``(x, y)`` and ``(c, s)`` rounds it on this
    machine: once (``fused``, as a fused multiply-add of ``x c`` onto ``y s``) or after each
    operation."""
    if fused:
        return fma(x, c, y * s)
    return x * c + y * s


def blas_dot_rounding() -> bool | None:
    """How numpy's ``(N, 2) @ (2,)`` rounds ``x c + y s`` here: True when it equals
    ``fma(x, c, y s)`` (rounded once), False when ``x c + y s`` rounded after each operation, None
    when neither (the engines then stand aside). Worked out exactly (fractions), on points whose
    two roundings differ, in several lengths and offsets of a larger array."""
    rng = np.random.default_rng(20261128)
    big = rng.uniform(-30.0, 30.0, (257, 2))
    fused = plain = True
    for lo, hi, angle in ((0, 257, 0.3), (1, 8, 2.0), (3, 40, -1.2), (5, 6, 2.9), (2, 133, -2.6)):
        c, s = math.cos(angle), math.sin(angle)
        got = big[lo:hi].dot(np.array([c, s])).tolist()
        for (x, y), g in zip(big[lo:hi].tolist(), got, strict=True):
            fused = fused and g == float(Fraction(x) * Fraction(c) + Fraction(y * s))
            plain = plain and g == x * c + y * s
    return True if fused else False if plain else None


#: :func:`blas_dot_rounding` of this machine.
FUSED_DOT = blas_dot_rounding()


# ---------------------------------------------------------------------------- the fused passes' arrays
# Where the fused passes of :func:`labkit.extract_features` keep what they take and hand back.
# A :class:`labkit.Config`'s numbers go to the passes (:func:`labkit._iav_engine.stage_pass`,
# :func:`labkit.lines._split_merge_engine.line_pass`) as two arrays, built once per Config
# (:func:`labkit._pipeline_engine.plan_for`) with a scan's own written into a copy: a numba dispatch
# checks the type of every argument, some 0.2 µs each, and a pass of thirty arguments paid 5 µs a
# call for it. The floats' places are the ``F_*`` names, the integers' (and flags') the ``I_*``.
# What the passes hand back is one float and one integer array each, rows of a fixed width per
# feature (the ``*_F`` and ``*_I`` names): each array numba hands back to Python costs about a
# microsecond.
F_SEG_M, F_LAM, F_SEG_SIGMA, F_INCREMENT = 0, 1, 2, 3
F_LEG_C_LO, F_LEG_C_HI, F_LEG_LO, F_LEG_HI, F_LEG_PAD, F_LEG_SIGMA = 4, 5, 6, 7, 8, 9
F_C_C_LO, F_C_C_HI, F_C_LO, F_C_HI, F_C_MEAN_LO, F_C_MEAN_HI, F_C_STD, F_C_STD_SQ, F_C_SIGMA = range(10, 19)
F_L_THRESHOLD, F_L_NOISE, F_L_ABSORB, F_L_GAP, F_L_MERGE_DR, F_L_MERGE_DA, F_L_MIN_LEN = range(19, 26)
F_L_FLOOR, F_L_LAM_CUT, F_L_LAM_GRAZE, F_L_SIGMA, F_L_PLACE_DR, F_L_PLACE_DA, F_L_PLACE_P = range(26, 33)
F_K_ANGLE, F_K_GAP, F_K_EXT, F_EARLY_FACTOR = range(33, 37)
N_F = 37
I_SEG_MIN, I_ADAPTIVE, I_FULL, I_LEGS, I_LEG_MIN, I_OCCLUDED, I_CIRCLES, I_C_MIN = range(8)
I_FIT, I_L_MIN, I_MERGE, I_UNIFORM, I_SKIP_ROUND, I_PLACE, I_CORNERS, I_FUSED, I_EARLY_STEPS = range(8, 17)
N_I = 17
LEG_F, LEG_I, CIRCLE_F, CIRCLE_I, LINE_F, LINE_I, CORNER_F, CORNER_I = 7, 3, 7, 3, 11, 5, 5, 2
N_T = 3  # stage_pass's floats start with the clock at the end of the segmentation, legs, circles (ns)
# the head of stage_pass's integer output: a status (0: done; 1: a case only Python computes, which the
# staged path hands to it), the legs and circles it holds
S_STATUS, S_LEGS, S_CIRCLES = range(3)
N_S = 3


# the head of line_pass's integer output: a status (0: done; 2: a placing too close to call, which
# the staged path hands to Python), the lines, corners and line beams it holds
H_STATUS, H_LINES, H_CORNERS, H_BEAMS = range(4)
N_H = 4
