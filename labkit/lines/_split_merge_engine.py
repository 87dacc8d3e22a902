"""Split-and-merge as one compiled pass over a scan (private: not part of labkit's API).

:func:`labkit.lines.split_and_merge` reads as the slides and runs this engine on its default path
(``trace=False``); with ``trace=True`` it runs its readable steps. The engine does the same
thing with the same arithmetic, in one numba-compiled call per scan instead of some two thousand
Python calls: the walls seen at a grazing angle joined (:func:`labkit.lines.split_merge.join_grazing_walls`),
the lists laid end to end with their prefix sums, the split loop with its gap, worst-point,
own-noise, residual and shift tests, the stranded points absorbed, the merge with its split and
beam-between tests, the short lines dropped and the merge again. What it returns is gathered
into :class:`labkit.LineSegment` records in bulk: the covariances and RMS errors in one vectorised
pass (:func:`labkit.lines._split_merge_fast.covariances`, the reference's own), then placing
(:func:`labkit.lines.placing.placed`).

Every floating-point operation is the reference's, in its order: elementwise products and sums
as numpy computes them, numpy's pairwise summation where the reference calls ``numpy.sum``
(:func:`labkit._kernels.pairwise_sum`), the C library's ``cos``, ``sin``, ``atan2``, ``hypot``
and ``pow`` as numpy and Python call them. So the lines are the reference's bit for bit
(``tests/test_engine.py``: random scans, the simulated worlds, the real recordings).
The chi-square merge (``merge="chi2"``) is not in the engine: it runs the reference.

Lines are kept in flat arrays: line ``k`` has its weighted sums ``S[k]``, its beams as a chain
of pieces (runs ``[a, b)`` of the list order; a merge links the chains) and its fit and ends.
"""

from __future__ import annotations

import math

import numpy as np

from .._kernels import (
    CORNER_F,
    CORNER_I,
    F_K_ANGLE,
    F_K_EXT,
    F_K_GAP,
    F_L_ABSORB,
    F_L_FLOOR,
    F_L_GAP,
    F_L_LAM_CUT,
    F_L_LAM_GRAZE,
    F_L_MERGE_DA,
    F_L_MERGE_DR,
    F_L_MIN_LEN,
    F_L_NOISE,
    F_L_PLACE_DA,
    F_L_PLACE_DR,
    F_L_PLACE_P,
    F_L_SIGMA,
    F_L_THRESHOLD,
    FUSED_DOT,
    H_BEAMS,
    H_CORNERS,
    H_LINES,
    H_STATUS,
    HALF_PI,
    I_CORNERS,
    I_FIT,
    I_FULL,
    I_FUSED,
    I_L_MIN,
    I_MERGE,
    I_PLACE,
    I_UNIFORM,
    LINE_F,
    LINE_I,
    N_H,
    PI,
    TWO_PI,
    dot2,
    jit,
    jit_inline,
    line_from_sums,
    monotonic_ns,
    pairwise_sum,
    py_hypot,
    remainder_2pi,
    segment_sum,
    sum_at,
)
from .._segmentation_engine import order as _order
from .._segmentation_engine import threshold as breakpoint_threshold
from ..features import LineSegment
from ..fitting import placement_probability
from ..noise import MIN_SPLIT_M, SPLIT_SIGMAS
from ..segmentation import SegmentationParams
from ._split_merge_fast import GRAZING_DEG

__all__ = ["extract", "split_and_merge", "line_pass", "READY"]

#: Whether the engine gives the reference's lines on this machine (its BLAS rounds a dot product in
#: a way :func:`labkit._kernels.dot2` reproduces); if not, split_and_merge runs its readable steps.
READY = FUSED_DOT is not None

_RESIDUAL_Z = 3.0  # (= split_merge.RESIDUAL_Z, SHIFT_Z, SHIFT_MIN_M: the engine cannot import the
_SHIFT_Z = 5.0  # module it serves; tests/test_engine.py checks they agree)
_SHIFT_MIN_M = 0.01
_SD_FLOOR = MIN_SPLIT_M / SPLIT_SIGMAS  # the least noise across a line, as the reference computes it


# ---------------------------------------------------------------------------- the walls at a grazing angle
@jit_inline
def _grazing_link(points, ranges, angles, k, floor_m, sigma, lam_cut, lam_graze):
    """Whether the breakpoints cut beams ``k`` and ``k + 1`` though they see one surface at a
    grazing angle (:func:`labkit.lines._split_merge_fast.grazing_links`)."""
    gap = math.hypot(points[k + 1, 0] - points[k, 0], points[k + 1, 1] - points[k, 1])
    dphi = abs(angles[k + 1] - angles[k])
    r_min = min(ranges[k], ranges[k + 1])
    return (gap > breakpoint_threshold(r_min, dphi, floor_m, lam_cut, sigma)
            and gap <= breakpoint_threshold(r_min, dphi, floor_m, lam_graze, sigma))


@jit
def _grazing_runs(points, ranges, angles, valid, labels, floor_m, min_points, sigma, lam_cut, lam_graze,
                  full_circle):
    """:func:`labkit.lines._split_merge_fast.grazing_runs`: the labels with the grazing walls
    joined, and the joined pairs (``joined[k]``: beams ``k, k + 1``); ``found`` False when none."""
    n = len(labels)
    nothing = np.zeros(n, np.bool_)
    if n < 2:
        return labels, nothing, False
    # pairs of lone beams, and whether min_points - 1 of them are in a row
    m = min_points - 1
    row = 0
    prev = -2
    enough = False
    n_pairs = 0
    for k in range(n - 1):
        if valid[k] and labels[k] < 0 and valid[k + 1] and labels[k + 1] < 0:
            n_pairs += 1
            row = row + 1 if prev == k - 1 else 1
            prev = k
            if row >= m:
                enough = True
    if n_pairs < m or not enough:
        return labels, nothing, False
    link = np.zeros(n - 1, np.bool_)
    for k in range(n - 1):
        if valid[k] and labels[k] < 0 and valid[k + 1] and labels[k + 1] < 0:
            link[k] = _grazing_link(points, ranges, angles, k, floor_m, sigma, lam_cut, lam_graze)
    # chains of links: beams firsts[j]..lasts[j]; the long ones
    firsts = np.empty(n, np.int64)
    lasts = np.empty(n, np.int64)
    n_chains = 0
    k = 0
    while k < n - 1:
        if link[k]:
            f = k
            while k < n - 1 and link[k]:
                k += 1
            if k - f + 1 >= min_points:
                firsts[n_chains] = f
                lasts[n_chains] = k
                n_chains += 1
        else:
            k += 1
    if n_chains == 0:
        return labels, nothing, False
    # the pairs between a chain and the segment it continues, either side
    for j in range(n_chains):
        for e in (firsts[j] - 1, lasts[j]):
            if 0 <= e < n - 1 and valid[e] and valid[e + 1]:
                if _grazing_link(points, ranges, angles, e, floor_m, sigma, lam_cut, lam_graze):
                    link[e] = True
    joined = np.zeros(n - 1, np.bool_)
    for j in range(n_chains):
        for k in range(max(firsts[j] - 1, 0), min(lasts[j] + 1, n - 1)):
            joined[k] = link[k]
    out = labels.copy()
    top = 0
    for i in range(n):
        top = max(top, labels[i] + 1)
    # runs of pairs joined or in one segment; a run with a new pair becomes one segment
    number = 0
    k = 0
    while k < n - 1:
        if joined[k] or (labels[k] == labels[k + 1] and labels[k] >= 0):
            f = k
            new = False
            while k < n - 1 and (joined[k] or (labels[k] == labels[k + 1] and labels[k] >= 0)):
                new = new or joined[k]
                k += 1
            if new:
                for i in range(f, k + 1):
                    out[i] = top + number
                number += 1
        else:
            k += 1
    if full_circle and labels[0] >= 0 and labels[0] == labels[n - 1] and out[0] != out[n - 1]:
        last = out[n - 1]
        for i in range(n):
            if out[i] == last:
                out[i] = out[0]
    # labels in scan order again: numbered where each segment starts; one across the seam keeps
    # the first number at its end too
    relabelled = np.full(n, -1, np.int64)
    count = -1
    last_start = -1
    for i in range(n):
        if out[i] >= 0:
            if i == 0 or out[i] != out[i - 1]:
                count += 1
                last_start = i
            relabelled[i] = count
    if out[0] >= 0 and out[0] == out[n - 1]:
        for i in range(last_start, n):
            if out[i] >= 0:
                relabelled[i] = 0
    for k in range(n - 1):
        joined[k] = joined[k] and not (labels[k] == labels[k + 1] and labels[k] >= 0)
    flags = np.zeros(n, np.bool_)
    for k in range(n - 1):
        flags[k] = joined[k]
    return relabelled, flags, True


# ---------------------------------------------------------------------------- the lists
@jit_inline
def _prefix_sums(X, Y, W):
    """Rows ``i``: the sums of ``w, w x, w y, w x x, w y y, w x y`` over points ``0..i-1``."""
    m = len(X)
    C = np.zeros((m + 1, 6))
    for i in range(m):
        w, x, y = W[i], X[i], Y[i]
        wx = w * x
        wy = w * y
        C[i + 1, 0] = C[i, 0] + w
        C[i + 1, 1] = C[i, 1] + wx
        C[i + 1, 2] = C[i, 2] + wy
        C[i + 1, 3] = C[i, 3] + wx * x
        C[i + 1, 4] = C[i, 4] + wy * y
        C[i + 1, 5] = C[i, 5] + wx * y
    return C


@jit_inline
def _fit(C, a, b):
    return line_from_sums(C[b, 0] - C[a, 0], C[b, 1] - C[a, 1], C[b, 2] - C[a, 2], C[b, 3] - C[a, 3],
                          C[b, 4] - C[a, 4], C[b, 5] - C[a, 5])


@jit_inline
def _chord(X, Y, a, b):
    x0, y0, x1, y1 = X[a], Y[a], X[b - 1], Y[b - 1]
    alpha = math.atan2(x1 - x0, -(y1 - y0))
    r = x0 * math.cos(alpha) + y0 * math.sin(alpha)
    if r < 0:
        r = -r
        alpha = alpha + PI
    return r, remainder_2pi(alpha)


@jit_inline
def _on_rays(x0, y0, x1, y1, r, alpha):
    """:func:`labkit.lines._runs._on_rays`: the segment's ends, stopped at its end beams' rays."""
    c, sn = math.cos(alpha), math.sin(alpha)
    d0 = x0 * c + y0 * sn - r
    d1 = x1 * c + y1 * sn - r
    sx, sy, ex, ey = x0 - d0 * c, y0 - d0 * sn, x1 - d1 * c, y1 - d1 * sn
    inside = x0 * y1 - y0 * x1
    if (x0 * sy - y0 * sx) * inside < 0 and r + d0 > 0:
        sx, sy = x0 * (r / (r + d0)), y0 * (r / (r + d0))
    if (x1 * ey - y1 * ex) * inside > 0 and r + d1 > 0:
        ex, ey = x1 * (r / (r + d1)), y1 * (r / (r + d1))
    return sx, sy, ex, ey


# ---------------------------------------------------------------------------- the split tests
@jit_inline
def _beyond_own_noise(V, RHO, lo, hi, r, sigma):
    """``split_merge._beyond_own_noise`` over ``V[lo:hi]``: the worst point in units of its own
    threshold (its position from ``lo``) and that ratio."""
    s5 = SPLIT_SIGMAS * sigma
    q = 0
    best = -1.0
    for i in range(lo, hi):
        ratio = abs(V[i] - r) / max(abs(V[i]) * s5 / RHO[i], MIN_SPLIT_M)
        if ratio > best or i == lo:
            best = ratio
            q = i - lo
    return q, best


@jit_inline
def _misfit(V, RHO, lo, hi, r, sigma, res, sd, zz, c, v2):
    """``split_merge._misfit`` of the points ``V[lo:hi]`` (their ranges ``RHO``): 0 none,
    1 "residual", 2 "shift" with the stretch ``(k, w)`` from ``lo``."""
    n = hi - lo
    if n <= 2:
        return 0, 0, 0
    for i in range(n):
        v = V[lo + i]
        res[i] = v - r
        s = abs(v)
        s *= sigma
        s /= RHO[lo + i]
        sd[i] = max(s, _SD_FLOOR)
        z = res[i] / sd[i]
        zz[i] = z * z
    total = pairwise_sum(zz, n)
    dof = n - 2
    k9 = 2.0 / (9.0 * dof)
    chi2 = max(1.0 - k9 + _RESIDUAL_Z * math.sqrt(k9), 0.0) ** 3.0
    if total > dof and total > dof * chi2:
        return 1, 0, 0
    if n < 8 or total <= _SHIFT_Z * _SHIFT_Z:
        return 0, 0, 0
    # shifted_stretch: running sums of the residuals and their variances
    c[0] = 0.0
    v2[0] = 0.0
    c[1] = res[0]
    v2[1] = sd[0] * sd[0]
    for i in range(1, n):
        c[i + 1] = c[i] + res[i]
        v2[i + 1] = v2[i] + sd[i] * sd[i]
    most = 0.0
    for i in range(n - 3):
        most = max(most, abs(c[i + 4] - c[i]))
    if most <= _SHIFT_MIN_M * 4:
        return 0, 0, 0
    found = False
    best_k, best_w, best_z = 0, 0, _SHIFT_Z
    w = 4
    while 2 * w <= n:
        k_w, z_w = 0, -1.0
        for k in range(n - w + 1):
            z = abs(c[k + w] - c[k]) / math.sqrt(v2[k + w] - v2[k])
            if z > z_w or k == 0:
                k_w, z_w = k, z
        if z_w > best_z and abs(c[k_w + w] - c[k_w]) > _SHIFT_MIN_M * w:
            found = True
            best_k, best_w, best_z = k_w, w, z_w
        w *= 2
    if found:
        return 2, best_k, best_w
    return 0, 0, 0


# ---------------------------------------------------------------------------- the whole scan
@jit
def extract(points, ranges, angles, valid, labels, fit, threshold_m, noise_sigma, absorb_m, min_points, max_gap_m,
            merge_on, merge_dr_m, merge_dalpha, min_length_m, uniform, floor_m, lam_cut, lam_graze, full_circle, fused):
    """The lines of one scan (see the module docstring), as arrays: per line ``r, alpha``, its
    segment's ends ``(sx, sy, ex, ey)``, first and last beams, and its beams (``beams[offsets[k]:
    offsets[k + 1]]``)."""
    n_beams = len(ranges)
    grazing = np.zeros(n_beams, np.bool_)
    has_grazing = False
    if noise_sigma > 0:
        labels, grazing, has_grazing = _grazing_runs(points, ranges, angles, valid, labels, floor_m, min_points,
                                                     noise_sigma, lam_cut, lam_graze, full_circle)
    order, bounds = _order(labels)
    m = len(order)
    X = np.empty(m)
    Y = np.empty(m)
    W = np.empty(m)
    RHO = np.empty(m)
    for i in range(m):
        j = order[i]
        X[i] = points[j, 0]
        Y[i] = points[j, 1]
        RHO[i] = ranges[j]
        W[i] = 1.0 if uniform else 1.0 / ranges[j]
    C = _prefix_sums(X, Y, W)
    # the gaps wider than max_gap_m, where a list may be cut (not where a grazing wall was joined)
    GAP = np.zeros(max(m - 1, 0))
    wide = np.empty(max(m - 1, 0), np.int64)
    n_wide = 0
    near = 0.99 * max_gap_m
    for i in range(m - 1):
        dx = X[i + 1] - X[i]
        dy = Y[i + 1] - Y[i]
        if abs(dx) + abs(dy) > near:
            gap = math.hypot(dx, dy)
            GAP[i] = gap
            joined = has_grazing and order[i + 1] == order[i] + 1 and grazing[order[i]]
            if gap > max_gap_m and not joined:
                wide[n_wide] = i
                n_wide += 1
    keep = min_points // 2
    V = np.empty(m)  # projections on the line under test (by position)
    scratch = np.empty((5, m + 1))
    stack_a = np.empty(2 * m + 4, np.int64)
    stack_b = np.empty(2 * m + 4, np.int64)
    acc_a = np.empty(m + 1, np.int64)
    acc_b = np.empty(m + 1, np.int64)
    left_a = np.empty(m + 1, np.int64)
    left_b = np.empty(m + 1, np.int64)
    by_end = np.full(m + 1, -1, np.int64)
    by_start = np.full(m + 1, -1, np.int64)
    span_a = np.empty(m + 1, np.int64)  # the accepted (and widened) runs of the scan, in order
    span_b = np.empty(m + 1, np.int64)
    n_spans = 0
    for seg in range(len(bounds) - 1):
        # steps 2-5 on the list bounds[seg]..bounds[seg + 1]
        stack_a[0], stack_b[0] = bounds[seg], bounds[seg + 1]
        top = 1
        n_acc = 0
        n_left = 0
        while top:
            top -= 1
            a, b = stack_a[top], stack_b[top]
            if b - a < min_points:
                left_a[n_left], left_b[n_left] = a, b
                n_left += 1
                continue
            # the widest gap wider than max_gap_m, if any: the first cut
            lo_w, hi_w = 0, n_wide
            while lo_w < hi_w:  # bisect_left(wide, a)
                mid = (lo_w + hi_w) // 2
                if wide[mid] < a:
                    lo_w = mid + 1
                else:
                    hi_w = mid
            if lo_w < n_wide and wide[lo_w] < b - 1:
                g = wide[lo_w]
                kk = lo_w + 1
                while kk < n_wide and wide[kk] < b - 1:
                    if GAP[wide[kk]] > GAP[g]:
                        g = wide[kk]
                    kk += 1
                stack_a[top], stack_b[top] = g + 1, b
                stack_a[top + 1], stack_b[top + 1] = a, g + 1
                top += 2
                continue
            if fit:
                r, alpha = _fit(C, a, b)
            else:
                r, alpha = _chord(X, Y, a, b)
            # step 3: the worst point
            n = b - a
            if n > 2 * keep:
                lo, hi = a + keep, b - keep
            else:
                lo, hi = a, b
            c, s = math.cos(alpha), math.sin(alpha)
            k_hi = k_lo = lo
            for i in range(lo, hi):
                V[i] = dot2(X[i], Y[i], c, s, fused)  # (as numpy's points @ (c, s))
                if V[i] > V[k_hi]:
                    k_hi = i
                if V[i] < V[k_lo]:
                    k_lo = i
            d_hi, d_lo = V[k_hi] - r, r - V[k_lo]
            if d_hi > d_lo or (d_hi == d_lo and k_hi < k_lo):
                p, worst = k_hi, d_hi
            else:
                p, worst = k_lo, d_lo
            # step 4: is it a line?
            failed = worst > threshold_m
            if noise_sigma > 0 and not failed and a < p < b - 1 and worst > MIN_SPLIT_M:
                q, ratio = _beyond_own_noise(V, RHO, np.int64(lo), np.int64(hi), r, noise_sigma)
                if ratio > 1.0:
                    failed = True
                    p = lo + q
            misfit, k_s, w_s = 0, 0, 0
            if noise_sigma > 0 and not failed and n > 2:
                if fit:
                    rf, af = r, alpha
                else:
                    rf, af = _fit(C, a, b)
                cf, sf = math.cos(af), math.sin(af)
                for i in range(a, b):
                    V[i] = dot2(X[i], Y[i], cf, sf, fused)
                misfit, k_s, w_s = _misfit(V, RHO, np.int64(a), np.int64(b), rf, noise_sigma, scratch[0], scratch[1],
                                           scratch[2], scratch[3], scratch[4])
                if misfit == 1 and a < p < b - 1:
                    failed = True
            if failed and a < p < b - 1:  # step 5: split at the worst point, which ends the left half
                stack_a[top], stack_b[top] = p + 1, b
                stack_a[top + 1], stack_b[top + 1] = a, p + 1
                top += 2
            elif misfit == 2:  # cut the shifted stretch out
                c0, c1 = a + k_s, a + k_s + w_s
                for lo_p, hi_p in ((c1, b), (c0, c1), (a, c0)):
                    if hi_p > lo_p:
                        stack_a[top], stack_b[top] = lo_p, hi_p
                        top += 1
            else:
                acc_a[n_acc], acc_b[n_acc] = a, b
                n_acc += 1
        # the accepted runs in order, widened by the stranded points that fit them
        sa = np.empty(n_acc, np.int64)
        sb = np.empty(n_acc, np.int64)
        for k in range(n_acc):
            sa[k], sb[k] = acc_a[k], acc_b[k]
        for k in range(1, n_acc):  # (insertion sort by start: the runs are disjoint)
            ka, kb = sa[k], sb[k]
            j = k - 1
            while j >= 0 and sa[j] > ka:
                sa[j + 1], sb[j + 1] = sa[j], sb[j]
                j -= 1
            sa[j + 1], sb[j + 1] = ka, kb
        if n_left and n_acc:
            for k in range(n_acc):
                by_end[sb[k]] = k
                by_start[sa[k]] = k
            wa = sa.copy()
            wb = sb.copy()
            for j in range(n_left):
                a, b = left_a[j], left_b[j]
                left, right = by_end[a], by_start[b]
                lo, hi = a, b
                while lo < hi:
                    d = _distance(C, X, Y, RHO, sa, sb, left, lo, absorb_m, noise_sigma)
                    if not (d <= absorb_m and d <= _distance(C, X, Y, RHO, sa, sb, right, lo, absorb_m,
                                                             noise_sigma)):
                        break
                    lo += 1
                while hi > lo and _distance(C, X, Y, RHO, sa, sb, right, hi - 1, absorb_m, noise_sigma) <= absorb_m:
                    hi -= 1
                if left >= 0:
                    wb[left] = lo
                if right >= 0:
                    wa[right] = hi
            for k in range(n_acc):
                by_end[sb[k]] = -1
                by_start[sa[k]] = -1
            sa, sb = wa, wb
        for k in range(n_acc):
            span_a[n_spans], span_b[n_spans] = sa[k], sb[k]
            n_spans += 1
    # the lines: sums, fits, ends; beams as chains of pieces
    K = n_spans
    S = np.empty((K, 6))
    R = np.empty(K)
    AL = np.empty(K)
    ENDS = np.empty((K, 4))
    PF = np.empty((K, 2))
    PL = np.empty((K, 2))
    FIRST = np.empty(K, np.int64)
    LAST = np.empty(K, np.int64)
    HEAD = np.arange(K)
    TAIL = np.arange(K)
    NEXT = np.full(K, -1, np.int64)
    for k in range(K):
        a, b = span_a[k], span_b[k]
        for col in range(6):
            S[k, col] = C[b, col] - C[a, col]
        FIRST[k], LAST[k] = order[a], order[b - 1]
        PF[k, 0], PF[k, 1], PL[k, 0], PL[k, 1] = X[a], Y[a], X[b - 1], Y[b - 1]
        R[k], AL[k] = line_from_sums(S[k, 0], S[k, 1], S[k, 2], S[k, 3], S[k, 4], S[k, 5])
        ENDS[k, 0], ENDS[k, 1], ENDS[k, 2], ENDS[k, 3] = _on_rays(PF[k, 0], PF[k, 1], PL[k, 0], PL[k, 1], R[k],
                                                                  AL[k])
    lines = np.arange(K)
    n_lines = K
    work = np.empty((5, m + 1))
    VV = np.empty(m + 1)
    RR = np.empty(m + 1)
    # step 6: merge similar neighbours; drop the lines too short, then merge the new neighbours
    if merge_on:
        n_lines = _merge(lines, np.int64(n_lines), S, R, AL, ENDS, PF, PL, FIRST, LAST, HEAD, TAIL, NEXT, span_a,
                         span_b, order, points, ranges, angles, valid, threshold_m, noise_sigma, max_gap_m, merge_dr_m,
                         merge_dalpha, floor_m, lam_cut, lam_graze, full_circle, VV, RR, work)
    kept = 0
    for i in range(n_lines):
        k = lines[i]
        dx, dy = ENDS[k, 2] - ENDS[k, 0], ENDS[k, 3] - ENDS[k, 1]
        if not math.sqrt(dx * dx + dy * dy) < min_length_m:
            lines[kept] = k
            kept += 1
    if merge_on and 1 < kept < n_lines:
        kept = _merge(lines, np.int64(kept), S, R, AL, ENDS, PF, PL, FIRST, LAST, HEAD, TAIL, NEXT, span_a, span_b,
                      order, points, ranges, angles, valid, threshold_m, noise_sigma, max_gap_m, merge_dr_m,
                      merge_dalpha, floor_m, lam_cut, lam_graze, full_circle, VV, RR, work)
    # the kept lines' beams, laid end to end
    offsets = np.zeros(kept + 1, np.int64)
    for i in range(kept):
        total = 0
        p = HEAD[lines[i]]
        while p >= 0:
            total += span_b[p] - span_a[p]
            p = NEXT[p]
        offsets[i + 1] = offsets[i] + total
    beams = np.empty(offsets[kept], np.int64)
    for i in range(kept):
        o = offsets[i]
        p = HEAD[lines[i]]
        while p >= 0:
            for t in range(span_a[p], span_b[p]):
                beams[o] = order[t]
                o += 1
            p = NEXT[p]
    r_out = np.empty(kept)
    alpha_out = np.empty(kept)
    ends_out = np.empty((kept, 4))
    first_out = np.empty(kept, np.int64)
    last_out = np.empty(kept, np.int64)
    for i in range(kept):
        k = lines[i]
        r_out[i], alpha_out[i], first_out[i], last_out[i] = R[k], AL[k], FIRST[k], LAST[k]
        for col in range(4):
            ends_out[i, col] = ENDS[k, col]
    return r_out, alpha_out, ends_out, first_out, last_out, beams, offsets


@jit_inline
def _distance(C, X, Y, RHO, sa, sb, k, i, threshold_m, noise_sigma):
    """How far point ``i`` lies from accepted line ``k`` (inf for none), in units of the absorb
    threshold at its incidence (``split_merge._absorb``'s ``distance``)."""
    if k < 0:
        return math.inf
    r, alpha = _fit(C, sa[k], sb[k])
    c, s = math.cos(alpha), math.sin(alpha)
    v = X[i] * c + Y[i] * s
    if noise_sigma > 0:
        return abs(v - r) * threshold_m / min(threshold_m, 3.0 * max(noise_sigma * abs(v) / RHO[i], _SD_FLOOR))
    return abs(v - r)


@jit
def _merge(lines, n_lines, S, R, AL, ENDS, PF, PL, FIRST, LAST, HEAD, TAIL, NEXT, span_a, span_b, order,
           points, ranges, angles, valid, threshold_m, noise_sigma, max_gap_m, merge_dr_m, merge_dalpha,
           floor_m, lam_cut, lam_graze, full_circle, VV, RR, work):
    """``split_merge._Merging.merge``: every pair of similar neighbours merged, left to right,
    then across the seam; returns the number of lines left in ``lines``."""
    if n_lines < 2:
        return n_lines
    i = 0
    while i < n_lines - 1:
        if _attempt(lines[i], lines[i + 1], S, R, AL, ENDS, PF, PL, FIRST, LAST, HEAD, TAIL, NEXT, span_a, span_b,
                    order, points, ranges, angles, valid, threshold_m, noise_sigma, max_gap_m, merge_dr_m,
                    merge_dalpha, floor_m, lam_cut, lam_graze, VV, RR, work):
            for j in range(i + 1, n_lines - 1):
                lines[j] = lines[j + 1]
            n_lines -= 1
        else:
            i += 1
    if full_circle and n_lines > 1:
        if _attempt(lines[n_lines - 1], lines[0], S, R, AL, ENDS, PF, PL, FIRST, LAST, HEAD, TAIL, NEXT, span_a,
                    span_b, order, points, ranges, angles, valid, threshold_m, noise_sigma, max_gap_m, merge_dr_m,
                    merge_dalpha, floor_m, lam_cut, lam_graze, VV, RR, work):
            lines[0] = lines[n_lines - 1]  # [merged] + the lines between
            n_lines -= 1
    return n_lines


@jit
def _attempt(a, b, S, R, AL, ENDS, PF, PL, FIRST, LAST, HEAD, TAIL, NEXT, span_a, span_b, order, points, ranges,
             angles, valid, threshold_m, noise_sigma, max_gap_m, merge_dr_m, merge_dalpha, floor_m, lam_cut,
             lam_graze, VV, RR, work):
    """``split_merge._Merging._attempt``: merge line ``b`` into line ``a`` (its slot) if they are
    neighbours, similar, and the merged line passes the split and beam-between tests."""
    # neighbours: facing ends within max_gap_m, or beams cut only for a grazing angle
    dx, dy = ENDS[b, 0] - ENDS[a, 2], ENDS[b, 1] - ENDS[a, 3]
    if not (math.sqrt(dx * dx + dy * dy) <= max_gap_m or (
            noise_sigma > 0 and FIRST[b] == LAST[a] + 1
            and _grazing_link(points, ranges, angles, LAST[a], floor_m, noise_sigma, lam_cut, lam_graze))):
        return False
    # similar: |dr| and |dalpha| under the thresholds (the normal turned around near the origin)
    da = remainder_2pi(AL[b] - AL[a])
    dr = R[b] - R[a]
    if abs(da) > HALF_PI:
        da = remainder_2pi(da - PI)
        dr = -R[b] - R[a]
    if not max(abs(dr) / merge_dr_m, abs(da) / merge_dalpha) < 1.0:
        return False
    # the merged line, refitted from the summed sums
    s0, s1, s2 = S[a, 0] + S[b, 0], S[a, 1] + S[b, 1], S[a, 2] + S[b, 2]
    s3, s4, s5 = S[a, 3] + S[b, 3], S[a, 4] + S[b, 4], S[a, 5] + S[b, 5]
    r, alpha = line_from_sums(s0, s1, s2, s3, s4, s5)
    c, s = math.cos(alpha), math.sin(alpha)
    n = 0
    for line in (a, b):
        p = HEAD[line]
        while p >= 0:
            for t in range(span_a[p], span_b[p]):
                j = order[t]
                VV[n] = points[j, 0] * c + points[j, 1] * s
                RR[n] = ranges[j]
                n += 1
            p = NEXT[p]
    # the split test of the merged line
    worst = 0.0
    for i in range(n):
        worst = max(worst, abs(VV[i] - r))
    if worst > threshold_m:
        return False
    if noise_sigma > 0:
        zero, n = np.int64(0), np.int64(n)  # (no literal: numba would compile the callees again for Literal[int](0))
        if worst > MIN_SPLIT_M and _beyond_own_noise(VV, RR, zero, n, r, noise_sigma)[1] > 1.0:
            return False
        if _misfit(VV, RR, zero, n, r, noise_sigma, work[0], work[1], work[2], work[3], work[4])[0] != 0:
            return False
    # no valid beam between them ending more than max_gap_m in front of or behind the merged line
    after, before = LAST[a], FIRST[b]
    if before != after + 1:
        nb = len(ranges)
        j = after + 1
        while True:
            if before > after:
                if j >= before:
                    break
            else:
                if j == nb:
                    j = 0
                if j >= before and j < after + 1:
                    break
            cj = math.cos(angles[j] - alpha)
            if valid[j] and cj > 0 and abs(ranges[j] * cj - r) > max_gap_m * cj:
                return False
            j += 1
    # merged: line a takes b's beams, sums and last end
    S[a, 0], S[a, 1], S[a, 2], S[a, 3], S[a, 4], S[a, 5] = s0, s1, s2, s3, s4, s5
    R[a], AL[a] = r, alpha
    PL[a, 0], PL[a, 1] = PL[b, 0], PL[b, 1]
    LAST[a] = LAST[b]
    ENDS[a, 0], ENDS[a, 1], ENDS[a, 2], ENDS[a, 3] = _on_rays(PF[a, 0], PF[a, 1], PL[a, 0], PL[a, 1], r, alpha)
    NEXT[TAIL[a]] = HEAD[b]
    TAIL[a] = TAIL[b]
    return True


# ---------------------------------------------------------------------------- records
@jit
def _covariances(points, ranges, beams, offsets, alpha, r, uniform, sigma):
    """:func:`labkit.fitting.line_covariances_rms` of the lines (ray noise ``sigma``, weights
    ``1 / rho`` or uniform), line by line with its sums as numpy forms them: ``numpy.sum`` for a
    single line, ``numpy.add.reduceat`` for several (and for the RMS errors always)."""
    k_lines = len(r)
    n_all = offsets[k_lines]
    cov = np.empty((k_lines, 2, 2))
    rms = np.empty(k_lines)
    X = np.empty(n_all)
    Y = np.empty(n_all)
    W = np.empty(n_all)
    T = np.empty((6, n_all))
    for i in range(n_all):
        j = beams[i]
        X[i], Y[i] = points[j, 0], points[j, 1]
        W[i] = 1.0 if uniform else 1.0 / ranges[j]
    single = k_lines == 1
    var = sigma * sigma
    for k in range(k_lines):
        lo, hi = offsets[k], offsets[k + 1]
        n = hi - lo
        for i in range(lo, hi):
            T[0, i] = W[i] * X[i]
            T[1, i] = W[i] * Y[i]
        if single:
            sw = sum_at(W, lo, n)
            xm, ym = sum_at(T[0], lo, n) / sw, sum_at(T[1], lo, n) / sw
        else:
            sw = segment_sum(W, lo, n)
            xm, ym = segment_sum(T[0], lo, n) / sw, segment_sum(T[1], lo, n) / sw
        for i in range(lo, hi):
            dx, dy = X[i] - xm, Y[i] - ym
            T[0, i] = W[i] * dx * dy
            T[1, i] = W[i] * (dx * dx - dy * dy)
        if single:
            num, den = 2.0 * sum_at(T[0], lo, n), sum_at(T[1], lo, n)
        else:
            num, den = 2.0 * segment_sum(T[0], lo, n), segment_sum(T[1], lo, n)
        q = num * num + den * den
        ca, sa = math.cos(alpha[k]), math.sin(alpha[k])
        lever = -xm * sa + ym * ca
        for i in range(lo, hi):
            w = W[i]
            dx, dy = X[i] - xm, Y[i] - ym
            ax = w * (den * dy - num * dx) / q
            ay = w * (den * dx + num * dy) / q
            share = w / sw
            rx = share * ca + lever * ax
            ry = share * sa + lever * ay
            rho = math.hypot(X[i], Y[i])
            c, s = X[i] / rho, Y[i] / rho
            jr, ja = rx * c + ry * s, ax * c + ay * s
            var_jr = var * jr
            T[2, i] = var_jr * jr
            T[3, i] = var_jr * ja
            T[4, i] = var * ja * ja
            d = X[i] * ca + Y[i] * sa - r[k]
            T[5, i] = d * d
        for a, b, row in ((0, 0, 2), (0, 1, 3), (1, 1, 4)):
            cov[k, a, b] = sum_at(T[row], lo, n) if single else segment_sum(T[row], lo, n)
        cov[k, 1, 0] = cov[k, 0, 1]
        if q == 0:
            for a in range(2):
                for b in range(2):
                    cov[k, a, b] = np.nan
        rms[k] = math.sqrt(segment_sum(T[5], lo, n) / n)
    return cov, rms


_GL_U, _GL_W = np.polynomial.legendre.leggauss(24)  # (= labkit.fitting's nodes and weights)
PLACING_NODES, PLACING_WEIGHTS = _GL_U, _GL_W  # (the arguments lines_pass takes for them)
_NEAR = 1e-9  # a probability this close to place_confidence is decided by the reference itself


_ERF_ONE = 6.0  # from here on the approximation of erf below is exactly 1 (tests/test_engine.py)


@jit
def _normal_cdf(x):
    z = abs(x) / math.sqrt(2.0)
    if z >= _ERF_ONE:  # (poly exp(-z^2) < 2^-54 there: 1 - it rounds to 1, and the exp is not needed)
        return 1.0 if x > 0 else 0.0
    t = 1.0 / (1.0 + 0.3275911 * z)
    poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))))
    erf = 1.0 - poly * math.exp(-z * z)
    return 0.5 * (1.0 + math.copysign(erf, x))


@jit
def _placing(cov, max_dr_m, max_dalpha, confidence, nodes, weights):
    """Per line: placed by :func:`labkit.fitting.placement_probability` (1), not (0), or too
    close to ``confidence`` to tell without the reference's own summation order (2). The
    probability is the reference's integral (the same nodes and pieces) summed in another order:
    it differs by a few units in the 15th digit at most. The middle piece comes first, and a line
    it already places is placed (the other pieces are integrals of a non-negative function)."""
    k_lines = len(cov)
    out = np.empty(k_lines, np.int64)
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(k_lines):
        var_r, var_a, c_ra = cov[k, 0, 0], cov[k, 1, 1], cov[k, 0, 1]
        if not (math.isfinite(var_r) and math.isfinite(var_a) and math.isfinite(c_ra)):
            out[k] = 0  # (a NaN covariance: probability 0)
            continue
        sd_a = math.sqrt(var_a)
        half = min(max_dalpha / sd_a, 8.0)
        va = var_a if var_a > 0 else 1.0
        slope = c_ra / va * sd_a
        sd_r = math.sqrt(max(var_r - c_ra * c_ra / va, 1e-300))
        b = min(max_dr_m / abs(slope), half)
        lo[0], lo[1], lo[2] = -b, -half, b  # (the middle piece first: it holds most of the probability)
        hi[0], hi[1], hi[2] = b, -b, half
        p = 0.0
        for piece in range(3):
            mid, rad = (hi[piece] + lo[piece]) / 2, (hi[piece] - lo[piece]) / 2
            acc = 0.0
            for j in range(len(nodes)):
                u = mid + rad * nodes[j]
                mu = slope * u
                inside = _normal_cdf((max_dr_m - mu) / sd_r) - _normal_cdf((-max_dr_m - mu) / sd_r)
                acc += math.exp(-0.5 * u * u) / math.sqrt(2 * math.pi) * inside * weights[j]
            p += acc * rad
            if p > confidence + _NEAR and p <= 1.0:  # the pieces left add no less than 0: placed
                break
        if not math.isfinite(p):
            p = 0.0
        p = min(max(p, 0.0), 1.0)
        if abs(p - confidence) <= _NEAR:
            out[k] = 2
        else:
            out[k] = 1 if p >= confidence else 0
    return out


@jit
def lines_pass(points, ranges, angles, valid, labels, fit, threshold_m, noise_sigma, absorb_m, min_points, max_gap_m,
               merge_on, merge_dr_m, merge_dalpha, min_length_m, uniform, floor_m, lam_cut, lam_graze, full_circle,
               fused, sigma, place_on, place_dr_m, place_dalpha, place_confidence, nodes, weights):
    """:func:`extract`, :func:`_covariances` and :func:`_placing` in one call, their results in three
    arrays (each array numba hands back to Python costs about a microsecond, each call a few): per
    line a row of floats ``r, alpha, rms, sx, sy, ex, ey, cov (4)``, a row of integers ``first, last,
    offset, next offset, placed`` (as :func:`_placing`: 1, 0 or 2; 1 when ``place_on`` is off), and
    the beams of every line end to end."""
    r, alpha, ends, first, last, beams, offsets = extract(
        points, ranges, angles, valid, labels, fit, threshold_m, noise_sigma, absorb_m, min_points, max_gap_m,
        merge_on, merge_dr_m, merge_dalpha, min_length_m, uniform, floor_m, lam_cut, lam_graze, full_circle, fused)
    k_lines = len(r)
    cov, rms = _covariances(points, ranges, beams, offsets, alpha, r, uniform, sigma)
    if place_on:
        verdict = _placing(cov, place_dr_m, place_dalpha, place_confidence, nodes, weights)
    else:
        verdict = np.ones(k_lines, np.int64)
    out = np.empty((k_lines, 11))
    ints = np.empty((k_lines, 5), np.int64)
    for k in range(k_lines):
        out[k, 0], out[k, 1], out[k, 2] = r[k], alpha[k], rms[k]
        for c in range(4):
            out[k, 3 + c] = ends[k, c]
        out[k, 7], out[k, 8], out[k, 9], out[k, 10] = cov[k, 0, 0], cov[k, 0, 1], cov[k, 1, 0], cov[k, 1, 1]
        ints[k, 0], ints[k, 1], ints[k, 2], ints[k, 3], ints[k, 4] = first[k], last[k], offsets[k], offsets[k + 1], \
            verdict[k]
    return out, ints, beams


def records(out: np.ndarray, ints: np.ndarray, beams: np.ndarray, place_dr_m: float, place_dalpha_deg: float,
            place_confidence: float) -> list[LineSegment]:
    """:class:`labkit.LineSegment` records of :func:`lines_pass`'s lines, less those the data cannot
    place (:func:`labkit.lines.placing.placed`), built in bulk."""
    return placed_records(out, ints, beams, place_dr_m, place_dalpha_deg, place_confidence)[0]


def placed_records(out: np.ndarray, ints: np.ndarray, beams: np.ndarray, place_dr_m: float, place_dalpha_deg: float,
                   place_confidence: float) -> tuple[list[LineSegment], list[int]]:
    """:func:`records`, and the rows of ``out`` they were built from."""
    if not len(out):
        return [], []
    out.setflags(write=False)
    beams.setflags(write=False)
    cov = out[:, 7:].reshape(-1, 2, 2)
    rows, irows = out.tolist(), ints.tolist()
    if place_confidence > 0 and any(row[4] == 2 for row in irows):  # a near tie: the reference's own sum decides
        chance = np.asarray(placement_probability(np.ascontiguousarray(cov), place_dr_m,
                                                  math.radians(place_dalpha_deg)))
        for i, row in enumerate(irows):
            if row[4] == 2:
                row[4] = int(chance[i] >= place_confidence)
    starts, ends = out[:, 3:5], out[:, 5:7]
    keep = [i for i, g in enumerate(irows) if g[4]]
    lines = []
    for i in keep:
        f, g = rows[i], irows[i]
        lines.append(LineSegment(f[0], f[1], cov[i], starts[i], ends[i], g[0], g[1], g[3] - g[2], f[2],
                                 beams[g[2]:g[3]]))
    return lines, keep


@jit_inline
def _wrap1(angle):
    """``labkit._plainfloat.wrap1``."""
    return PI - (PI - angle) % TWO_PI


@jit
def corners_pass(out, ints, keep, min_angle, max_gap_m, max_extension_m, wrap):
    """:func:`labkit.find_corners` of the lines ``keep`` (rows of :func:`lines_pass`'s ``out`` and
    ``ints``), in the same float arithmetic (``labkit._plainfloat``'s ``wrap1`` and ``intersect1``,
    Python's ``min``, ``max`` and ``math.hypot``: :func:`labkit._kernels.py_hypot`): per corner a
    row ``x, y, angle, concave, extrapolated, i, j`` (``i, j`` the lines' places in ``keep``)."""
    n = len(keep)
    n_pairs = max(n - 1, 0) + (1 if wrap and n > 2 else 0)
    rows = np.empty((n_pairs, 7))
    m = 0
    for q in range(n_pairs):
        i = q
        j = q + 1 if q < n - 1 else 0
        a, b = keep[i], keep[j]
        d = abs(_wrap1(out[a, 1] - out[b, 1]))
        angle = PI - d if PI - d < d else d
        if angle < min_angle:
            continue
        asx, asy, aex, aey = out[a, 3], out[a, 4], out[a, 5], out[a, 6]
        bsx, bsy, bex, bey = out[b, 3], out[b, 4], out[b, 5], out[b, 6]
        gap = py_hypot(bsx - aex, bsy - aey)
        if gap > max_gap_m:
            continue
        r1, r2 = out[a, 0], out[b, 0]
        c1, s1, c2, s2 = math.cos(out[a, 1]), math.sin(out[a, 1]), math.cos(out[b, 1]), math.sin(out[b, 1])
        if abs(c2) > abs(c1):
            c1, s1, r1, c2, s2, r2 = c2, s2, r2, c1, s1, r1
        f = c2 * (1.0 / c1)
        u = s2 - f * s1
        if abs(c1 * u) < 1e-12:
            continue
        y = (r2 - f * r1) / u
        x = (r1 - s1 * y) / c1
        e1, e2 = py_hypot(x - aex, y - aey), py_hypot(x - bsx, y - bsy)
        extension = e2 if e2 > e1 else e1
        allowed = max_extension_m
        if ints[b, 0] - ints[a, 1] == 1 and gap > allowed:
            allowed = gap
        side_origin = (bex - asx) * (0.0 - asy) - (bey - asy) * (0.0 - asx)
        side_corner = (bex - asx) * (y - asy) - (bey - asy) * (x - asx)
        rows[m, 0], rows[m, 1], rows[m, 2] = x, y, angle
        rows[m, 3] = 1.0 if side_origin * side_corner < 0 else 0.0
        rows[m, 4] = 1.0 if extension > allowed else 0.0
        rows[m, 5], rows[m, 6] = i, j
        m += 1
    return rows[:m]


@jit
def line_pass(points, ranges, angles, valid, labels, fp, ip):
    """The lines of :func:`labkit._pipeline_engine.extract` (:func:`lines_pass`, the lines
    placed kept) and their corners (``corners_pass``) in one compiled call: one float array (the
    clock at the end of the lines and of the corners, ns; per line ``r, alpha, rms, sx, sy, ex, ey,
    cov (4)``; per corner ``x, y, angle, concave, extrapolated``) and one integer array (the head
    ``H_*``; per line ``first, last, offset, next offset, placed``; per corner its lines' places;
    the lines' beams)."""
    full = ip[I_FULL] != 0
    out, ints, beams = lines_pass(
        points, ranges, angles, valid, labels, ip[I_FIT] != 0, fp[F_L_THRESHOLD], fp[F_L_NOISE], fp[F_L_ABSORB],
        ip[I_L_MIN], fp[F_L_GAP], ip[I_MERGE] != 0, fp[F_L_MERGE_DR], fp[F_L_MERGE_DA], fp[F_L_MIN_LEN],
        ip[I_UNIFORM] != 0, fp[F_L_FLOOR], fp[F_L_LAM_CUT], fp[F_L_LAM_GRAZE], full, ip[I_FUSED] != 0,
        fp[F_L_SIGMA], ip[I_PLACE] != 0, fp[F_L_PLACE_DR], fp[F_L_PLACE_DA], fp[F_L_PLACE_P], _GL_U, _GL_W)
    n_kept = 0
    for k in range(len(out)):
        if ints[k, 4] == 2:  # a near tie: the reference's own sum decides (in Python)
            io = np.zeros(N_H, np.int64)
            io[H_STATUS] = 2
            return np.zeros(2), io
        n_kept += ints[k, 4]
    keep = np.empty(n_kept, np.int64)
    n_kept = 0
    n_beams = 0
    for k in range(len(out)):
        if ints[k, 4]:
            keep[n_kept] = k
            n_kept += 1
            n_beams += ints[k, 3] - ints[k, 2]
    t_lines = monotonic_ns()
    corners = np.empty((0, 7))
    if ip[I_CORNERS] and n_kept > 1:
        corners = corners_pass(out, ints, keep, fp[F_K_ANGLE], fp[F_K_GAP], fp[F_K_EXT], full)
    n_corners = len(corners)
    t_corners = monotonic_ns()
    fo = np.empty(2 + LINE_F * n_kept + CORNER_F * n_corners)
    io = np.empty(N_H + LINE_I * n_kept + CORNER_I * n_corners + n_beams, np.int64)
    fo[0], fo[1] = t_lines, t_corners
    io[H_STATUS], io[H_LINES], io[H_CORNERS], io[H_BEAMS] = 0, n_kept, n_corners, n_beams
    f, i = 2, N_H
    offset = 0
    for k in keep:
        for c in range(LINE_F):
            fo[f + c] = out[k, c]
        f += LINE_F
        io[i], io[i + 1], io[i + 2] = ints[k, 0], ints[k, 1], offset
        io[i + 3] = offset + ints[k, 3] - ints[k, 2]
        io[i + 4] = ints[k, 4]
        offset = io[i + 3]
        i += LINE_I
    for q in range(n_corners):
        for c in range(CORNER_F):
            fo[f + c] = corners[q, c]
        io[i], io[i + 1] = int(corners[q, 5]), int(corners[q, 6])
        f += CORNER_F
        i += CORNER_I
    for k in keep:
        for b in range(ints[k, 2], ints[k, 3]):
            io[i] = beams[b]
            i += 1
    return fo, io


def split_and_merge(scan, labels, *, fit: bool, threshold_m: float, noise_sigma: float, absorb_m: float, sigma: float,
                    min_points: int, min_length_m: float, max_gap_m: float, merge: str, merge_dr_m: float,
                    merge_dalpha_deg: float, weights, floor_m: float, place_dr_m: float, place_dalpha_deg: float,
                    place_confidence: float) -> list[LineSegment]:
    """The default path of :func:`labkit.lines.split_and_merge` on the range segments ``labels``
    (the arguments resolved as it resolves them)."""
    out, ints, beams = lines_pass(
        scan.points, scan.ranges, scan.angles, scan.valid, labels, fit, float(threshold_m), float(noise_sigma),
        float(absorb_m), int(min_points), float(max_gap_m), merge != "none" and merge is not None, float(merge_dr_m),
        math.radians(merge_dalpha_deg), float(min_length_m), weights == "uniform", float(floor_m),
        math.radians(SegmentationParams.incidence_deg), math.radians(GRAZING_DEG), scan.is_full_circle, FUSED_DOT,
        float(sigma), place_confidence > 0, float(place_dr_m), math.radians(place_dalpha_deg), float(place_confidence),
        _GL_U, _GL_W)
    return records(out, ints, beams, place_dr_m, place_dalpha_deg, place_confidence)


def compile_all() -> None:
    """Compile (or load from numba's cache) every kernel of the engines, on a small made-up scan.
    The Makefile's set-up runs it, so that no notebook, test or command pays the compilation on
    its first scan."""
    from .._iav_engine import compile_all as compile_circles
    from .._noise_engine import residuals, robust_start
    from .._segmentation_engine import compile_all as compile_scan_kernels
    from .._segmentation_engine import labels as segment

    angles = np.radians(np.arange(-90.0, 90.5, 1.0))
    ranges = 2.0 / np.maximum(np.cos(angles), 0.3) + 0.002 * np.sin(7.0 * angles)
    points = np.stack([ranges * np.cos(angles), ranges * np.sin(angles)], axis=1)
    valid = np.ones(len(ranges), dtype=bool)
    # read-only arrays, as every Scan hands them over: numba compiles a kernel once per kind of
    # argument (a writable array is another kind), and only this kind is worth compiling ahead
    r, a, v, p = (_read_only(x) for x in (ranges, angles, valid, points))
    residuals(r, a, v, False)
    robust_start(r, a, v, False, 10, 1.4826, 3.5)  # (as labkit.noise.estimate_range_noise calls it)
    labels = segment(p, r, a, v, 0.08, 2, True, math.radians(10.0), 0.01, False, math.radians(1.0))
    out, ints, _ = lines_pass(p, r, a, v, labels, False, 0.05, 0.01, 0.03, 5, 0.3, True, 0.2, math.radians(10.0), 0.15,
                              False, 0.08, math.radians(10.0), math.radians(GRAZING_DEG), False, FUSED_DOT, 0.01,
                              True, 0.05, math.radians(3.0), 0.8, _GL_U, _GL_W)
    out.setflags(write=False)  # (as placed_records hands it over)
    corners_pass(out, ints, np.arange(len(out)), math.radians(30.0), 0.3, 0.1, False)
    from .._kernels import N_F, N_I, py_hypot_is_pythons

    line_pass(p, r, a, v, labels, np.zeros(N_F), np.zeros(N_I, np.int64))
    py_hypot_is_pythons()  # (its kernel: the fused path asks it once per process)
    compile_circles()
    compile_scan_kernels()


def _read_only(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a.setflags(write=False)
    return a
