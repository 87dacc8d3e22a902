"""The tracker's compiled kernels (private: not part of labkit's API).

:meth:`labkit.tracking.Tracker.step` runs, by default, the steps of :mod:`labkit.tracking` with
these kernels over all tracks at once instead of some two hundred numpy calls on arrays of a few
rows (each numpy call costs about a microsecond whatever the size, which made tracking a third of
the pipeline's time per scan):

* :func:`in_frame` -- :meth:`labkit.tracking.Detections.in_frame`: positions and covariances
  moved by the scan's pose;
* :func:`predict` -- :func:`labkit.tracking.cv_predict` in place, ``F P F' + Q`` written out for
  the constant-velocity ``F``;
* :func:`gate` -- the cost matrix of :meth:`labkit.tracking.Tracker._gate_all` (``d2 + ln det S``
  inside the gate, ``inf`` elsewhere, a static track's position covariance capped as in
  :meth:`~labkit.tracking.Tracker._static_gate_P`), and whether the assignment has a conflict (a
  track with two detections in its gate, or a detection in two gates). Without one, every pair
  inside a gate is assigned: that is the only assignment of the most pairs, so
  ``scipy.optimize.linear_sum_assignment`` is only called when there is a real choice;
* :func:`update` -- :func:`labkit.tracking.kalman_update` (the 2 x 2 inverse in closed form,
  Joseph form) of the assigned tracks in place, and their hits, last detection, anchor and
  "moved" bookkeeping;
* :func:`manage` -- a static circle track not detected at this scan put at rest, which tracks are
  confirmed (static or moving) and which are deleted;
* :func:`predict_and_gate`, :func:`update_and_manage` -- two of them in one call (a call from
  Python costs a few microseconds, more than the work on a few tracks; so does every array a
  kernel returns, hence the outputs the caller gives them); the first also moves the detections
  into the map (:func:`in_frame`), counts the scan in every track's age and lists the births
  (detections that start a track and lie outside every gate): a kernel call and four small numpy
  calls fewer;
* :func:`scan_step` -- the usual scan in one call: :func:`predict_and_gate`, then, when no
  detection starts a track and the pairs inside the gates are the assignment,
  :func:`update_and_manage` (otherwise the caller solves the assignment, adds the tracks and
  calls the others).

The readable code in :mod:`labkit.tracking` is the reference, and what ``trace=True`` runs; the
kernels compute the same formulas in another order of floating-point operations (loops instead of
numpy's matrix products), so states and covariances agree to rounding (``tests/test_tracking_engine.py``
checks ids, statuses and events equal and states to 1e-12 on the simulator's worlds and random
cases). ``LABKIT_NO_JIT=1`` runs the reference.
"""

from __future__ import annotations

import math

import numpy as np

from ._kernels import jit

__all__ = ["in_frame", "predict", "gate", "update", "manage", "predict_and_gate", "update_and_manage", "scan_step"]

TENTATIVE, STATIC, CONFIRMED, DELETED = 0, 1, 2, 3  # = labkit.tracking's status codes
CIRCLE = 1  # and its code of circle tracks (tests/test_tracking_engine.py)


@jit
def in_frame(z, R, x, y, theta, zm, Rm):
    """Positions ``z`` (D, 2) and covariances ``R`` (D, 2, 2) moved from the sensor frame by the
    pose ``(x, y, theta)``: ``rot z + t`` and ``rot R rot'``, into ``zm`` and ``Rm``."""
    c = math.cos(theta)
    s = math.sin(theta)
    for j in range(z.shape[0]):
        zm[j, 0] = (c * z[j, 0] - s * z[j, 1]) + x
        zm[j, 1] = (s * z[j, 0] + c * z[j, 1]) + y
        a = c * R[j, 0, 0] - s * R[j, 1, 0]  # rot R, row 0
        b = c * R[j, 0, 1] - s * R[j, 1, 1]
        e = s * R[j, 0, 0] + c * R[j, 1, 0]  # row 1
        f = s * R[j, 0, 1] + c * R[j, 1, 1]
        Rm[j, 0, 0] = a * c - b * s  # (rot R) rot'
        Rm[j, 0, 1] = a * s + b * c
        Rm[j, 1, 0] = e * c - f * s
        Rm[j, 1, 1] = e * s + f * c


@jit
def predict(x, P, dt, q):
    """States ``x`` (T, 4) and covariances ``P`` (T, 4, 4) ``dt`` seconds ahead, in place:
    ``x' = F x``, ``P' = F P F' + Q`` with ``Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]`` per axis."""
    qa = q * (dt**3 / 3.0)
    qb = q * (dt**2 / 2.0)
    qc = q * dt
    fp = np.empty((4, 4))
    for t in range(x.shape[0]):
        x[t, 0] = x[t, 0] + dt * x[t, 2]
        x[t, 1] = x[t, 1] + dt * x[t, 3]
        for j in range(4):  # F P: rows 0, 1 take dt times rows 2, 3
            fp[0, j] = P[t, 0, j] + dt * P[t, 2, j]
            fp[1, j] = P[t, 1, j] + dt * P[t, 3, j]
            fp[2, j] = P[t, 2, j]
            fp[3, j] = P[t, 3, j]
        for i in range(4):  # (F P) F': columns 0, 1 take dt times columns 2, 3
            P[t, i, 0] = fp[i, 0] + dt * fp[i, 2]
            P[t, i, 1] = fp[i, 1] + dt * fp[i, 3]
            P[t, i, 2] = fp[i, 2]
            P[t, i, 3] = fp[i, 3]
        P[t, 0, 0] += qa
        P[t, 1, 1] += qa
        P[t, 0, 2] += qb
        P[t, 2, 0] += qb
        P[t, 1, 3] += qb
        P[t, 3, 1] += qb
        P[t, 2, 2] += qc
        P[t, 3, 3] += qc


@jit
def gate(x, P, kind, status, z, R, det_kind, threshold, cap, cost, pairs, in_some):
    """Into ``cost`` (T, D): the cost ``d2 + ln det S`` of every track and detection of the same
    kind inside the gate (``d2 <= threshold``), ``inf`` elsewhere; into ``pairs`` (2, T D) the
    pairs inside (track, detection), row after row; into ``in_some`` (D,) whether each detection
    is inside some gate. Returns how many pairs, and whether some track or detection is inside
    two gates (an assignment problem to solve; else the pairs are the assignment). A static
    track's position covariance is scaled so that its largest eigenvalue is at most ``cap``
    (``min_travel_m^2 / threshold``). ``cost``, ``pairs`` and ``in_some`` may be larger (the
    tracker's work arrays): only the first T rows and D columns are written."""
    n_t = x.shape[0]
    n_d = z.shape[0]
    in_some[:] = False
    n_pairs = 0
    conflict = False
    for i in range(n_t):
        p00 = P[i, 0, 0]
        p01 = P[i, 0, 1]
        p10 = P[i, 1, 0]
        p11 = P[i, 1, 1]
        if status[i] == STATIC:
            largest = 0.5 * (p00 + p11) + math.sqrt(0.25 * (p00 - p11) ** 2 + p01 * p01)
            scale = min(1.0, cap / max(largest, 1e-300))
            p00 *= scale
            p01 *= scale
            p10 *= scale
            p11 *= scale
        in_row = 0
        for j in range(n_d):
            cost[i, j] = np.inf
            if det_kind[j] != kind[i]:
                continue
            a = p00 + R[j, 0, 0]
            b = p01 + R[j, 0, 1]
            c = p10 + R[j, 1, 0]
            d = p11 + R[j, 1, 1]
            det = a * d - b * c
            u = z[j, 0] - x[i, 0]
            v = z[j, 1] - x[i, 1]
            d2 = (d * u * u - (b + c) * u * v + a * v * v) / det
            if d2 <= threshold:
                cost[i, j] = d2 + math.log(det)
                pairs[0, n_pairs] = i
                pairs[1, n_pairs] = j
                n_pairs += 1
                in_row += 1
                if in_some[j]:
                    conflict = True
                in_some[j] = True
        if in_row > 1:
            conflict = True
    return n_pairs, conflict


@jit
def update(x, P, tracks, dets, z, R, hits, seen, anchor, far, moved, stamp_ns, confirm_hits, min_travel):
    """The Kalman update of track ``tracks[k]`` by detection ``dets[k]``, in place (gain
    ``P H' S^-1``, covariance in Joseph form, symmetrised), and its bookkeeping: one more hit,
    last seen at ``stamp_ns``, the anchor (the mean of its first ``confirm_hits`` detections),
    the updates in a row beyond ``min_travel`` from it, and whether it has moved."""
    K = np.empty((4, 2))
    A = np.empty((4, 4))
    AP = np.empty((4, 4))
    Pn = np.empty((4, 4))
    for k in range(tracks.shape[0]):
        i = tracks[k]
        j = dets[k]
        a = P[i, 0, 0] + R[j, 0, 0]
        b = P[i, 0, 1] + R[j, 0, 1]
        c = P[i, 1, 0] + R[j, 1, 0]
        d = P[i, 1, 1] + R[j, 1, 1]
        det = a * d - b * c
        i00 = d / det
        i01 = -b / det
        i10 = -c / det
        i11 = a / det
        for r in range(4):
            K[r, 0] = P[i, r, 0] * i00 + P[i, r, 1] * i10
            K[r, 1] = P[i, r, 0] * i01 + P[i, r, 1] * i11
        u = z[j, 0] - x[i, 0]
        v = z[j, 1] - x[i, 1]
        for r in range(4):
            x[i, r] = x[i, r] + (K[r, 0] * u + K[r, 1] * v)
        for r in range(4):  # A = I - K H
            for s in range(4):
                A[r, s] = (1.0 if r == s else 0.0) - (K[r, s] if s < 2 else 0.0)
        for r in range(4):
            for s in range(4):
                acc = 0.0
                for m in range(4):
                    acc += A[r, m] * P[i, m, s]
                AP[r, s] = acc
        for r in range(4):
            for s in range(4):
                acc = 0.0
                for m in range(4):
                    acc += AP[r, m] * A[s, m]
                kr0 = K[r, 0] * R[j, 0, 0] + K[r, 1] * R[j, 1, 0]
                kr1 = K[r, 0] * R[j, 0, 1] + K[r, 1] * R[j, 1, 1]
                Pn[r, s] = acc + (kr0 * K[s, 0] + kr1 * K[s, 1])
        for r in range(4):
            for s in range(4):
                P[i, r, s] = 0.5 * (Pn[r, s] + Pn[s, r])
        hits[i] += 1
        seen[i] = stamp_ns
        if hits[i] <= confirm_hits:
            anchor[i, 0] += (z[j, 0] - anchor[i, 0]) / hits[i]
            anchor[i, 1] += (z[j, 1] - anchor[i, 1]) / hits[i]
        if math.hypot(x[i, 0] - anchor[i, 0], x[i, 1] - anchor[i, 1]) > min_travel:
            far[i] += 1
        else:
            far[i] = 0
        if far[i] >= confirm_hits:
            moved[i] = True


@jit
def manage(x, kind, status, hits, scans, moved, seen, now_ns, confirm_hits, confirm_scans, max_coast_ns, confirmed,
           listed):
    """Rest, confirm and delete, in place on ``x`` and ``status``: a static circle track not
    detected at ``now_ns`` is put at rest (velocity zero); ``confirmed`` (T,) is set to 1 for a track confirmed
    static at this scan, 2 for one confirmed moving, 0 otherwise; ``listed`` (T,) to the status
    the scan's table lists (3 for a track deleted at this scan). Returns how many were confirmed
    and how many deleted."""
    n = status.shape[0]
    for i in range(n):
        if status[i] == STATIC and kind[i] == CIRCLE and seen[i] != now_ns:
            x[i, 2] = 0.0
            x[i, 3] = 0.0
    n_confirmed = 0
    for i in range(n):
        confirmed[i] = 0
        ready = status[i] == TENTATIVE and hits[i] >= confirm_hits
        if ready or (status[i] == STATIC and moved[i]):
            status[i] = CONFIRMED if moved[i] else STATIC
            confirmed[i] = 2 if moved[i] else 1
            n_confirmed += 1
    n_deleted = 0
    for i in range(n):
        hopeless = status[i] == TENTATIVE and scans[i] - hits[i] > confirm_scans - confirm_hits
        if hopeless or now_ns - seen[i] > max_coast_ns:
            listed[i] = DELETED
            n_deleted += 1
        else:
            listed[i] = status[i]
    return n_confirmed, n_deleted


@jit
def predict_and_gate(x, P, dt, q, scans, kind, status, z, R, in_map, px, py, ptheta, zm, Rm, det_kind, starts,
                     threshold, cap, cost, pairs, in_some, new):
    """One scan's first half in one call: the detections ``z``, ``R`` moved by the pose ``(px, py,
    ptheta)`` into ``zm``, ``Rm`` (:func:`in_frame`, when ``in_map``; else ``zm``, ``Rm`` are not
    read), one more scan for every track (``scans``), :func:`predict` (when ``dt > 0``) and
    :func:`gate` (of ``zm``, ``Rm`` in the map, of ``z``, ``R`` else); also, into ``new``, the
    detections that start a track (``starts``) and lie outside every gate (the births). Returns the
    pairs, the conflict and the births' count."""
    for i in range(scans.shape[0]):
        scans[i] += 1
    if dt > 0.0:
        predict(x, P, dt, q)
    if in_map:
        in_frame(z, R, px, py, ptheta, zm, Rm)
        n_pairs, conflict = gate(x, P, kind, status, zm, Rm, det_kind, threshold, cap, cost, pairs, in_some)
    else:
        n_pairs, conflict = gate(x, P, kind, status, z, R, det_kind, threshold, cap, cost, pairs, in_some)
    n_new = 0
    for j in range(z.shape[0]):
        if starts[j] and not in_some[j]:
            new[n_new] = j
            n_new += 1
    return n_pairs, conflict, n_new


@jit
def update_and_manage(x, P, tracks, dets, z, R, hits, seen, anchor, far, moved, kind, status, scans, now_ns,
                      confirm_hits, confirm_scans, min_travel, max_coast_ns, confirmed, listed, detection):
    """:func:`update` then :func:`manage`, in one call (a scan without births); ``detection`` (T,)
    is set to the detection that updated each track, -1 for none."""
    update(x, P, tracks, dets, z, R, hits, seen, anchor, far, moved, now_ns, confirm_hits, min_travel)
    detection[:] = -1
    for k in range(tracks.shape[0]):
        detection[tracks[k]] = dets[k]
    return manage(x, kind, status, hits, scans, moved, seen, now_ns, confirm_hits, confirm_scans, max_coast_ns,
                  confirmed, listed)


@jit
def scan_step(x, P, dt, q, scans, kind, status, z, R, in_map, px, py, ptheta, zm, Rm, det_kind, starts, threshold,
              cap, cost, pairs, in_some, new, hits, seen, anchor, far, moved, now_ns, confirm_hits, confirm_scans,
              min_travel, max_coast_ns, ids, born, out):
    """:func:`predict_and_gate`, then, when no detection starts a track and there is no conflict
    (the pairs inside the gates are the assignment), :func:`update_and_manage` with rows 0-2 of
    ``out`` (7, T) as its ``confirmed``, ``listed`` and ``detection``, and ``ids``, ``hits``,
    ``born`` and ``seen`` copied into rows 3-6 (the scan's table): a scan in one call. Returns the
    pairs, the conflict, the births' count, how many tracks were confirmed and deleted, and whether
    the scan is done (False: the caller goes on from the gate's outputs)."""
    n_pairs, conflict, n_new = predict_and_gate(x, P, dt, q, scans, kind, status, z, R, in_map, px, py, ptheta, zm,
                                                Rm, det_kind, starts, threshold, cap, cost, pairs, in_some, new)
    if conflict or n_new > 0:
        return n_pairs, conflict, n_new, 0, 0, False
    tracks = pairs[0, :n_pairs]
    dets = pairs[1, :n_pairs]
    if in_map:
        n_confirmed, n_deleted = update_and_manage(x, P, tracks, dets, zm, Rm, hits, seen, anchor, far, moved, kind,
                                                   status, scans, now_ns, confirm_hits, confirm_scans, min_travel,
                                                   max_coast_ns, out[0], out[1], out[2])
    else:
        n_confirmed, n_deleted = update_and_manage(x, P, tracks, dets, z, R, hits, seen, anchor, far, moved, kind,
                                                   status, scans, now_ns, confirm_hits, confirm_scans, min_travel,
                                                   max_coast_ns, out[0], out[1], out[2])
    for i in range(ids.shape[0]):
        out[3, i] = ids[i]
        out[4, i] = hits[i]
        out[5, i] = born[i]
        out[6, i] = seen[i]
    return n_pairs, False, 0, n_confirmed, n_deleted, True
