"""Graduated hints for the course notebooks' "your turn" cells: an idea, a stronger hint, then the solution.

A task cell says which name to ask for. ``hint("iepf")`` prints the first hint (an idea),
``hint("iepf", 2)`` a stronger one (the steps in words), and ``hint("iepf", "solution")`` prints the code
the notebook goes on with while the cell is a stub (labkit's own, from :mod:`labkit.course_fallbacks` or
the labkit function it names). The solution is an explicit request: the printout says it was shown, and
the name is recorded in :data:`SHOWN` for the rest of the session.

>>> hint("is_core")  # doctest: +ELLIPSIS
is_core, hint 1 of 2: A core point has at least min_pts points within eps, itself included. Next: ...
"""

from __future__ import annotations

import importlib
import inspect

__all__ = ["HINTS", "SOLUTIONS", "SHOWN", "hint"]

#: Per task: the hints, weakest first. None of them is a line of the answer.
HINTS: dict[str, tuple[str, ...]] = {
    "cut_points": (
        "Two neighbours belong together when their points are close. Which array holds the gaps between "
        "neighbouring points, and what does an invalid beam's point look like?",
        "Take the differences of consecutive points and their lengths; a cut is a gap that is not below the "
        "threshold. An invalid beam's point is NaN, and a comparison with NaN is False: decide cuts so that "
        "NaN gaps count as cuts.",
    ),
    "adaptive_threshold": (
        "The formula is in the cell above; the smaller of the two ranges is the one that matters.",
        "Convert the incidence angle to radians, take the element-wise minimum of the two range arrays, "
        "apply the law-of-sines formula, add three noise sigmas, then never return less than the floor.",
    ),
    "closed_form_alpha": (
        "The weighted sums of the derivation factor: no double loop is needed.",
        "Build the weighted means of x and y from the polar points, then the two sums that form the "
        "numerator and the denominator; alpha is half the angle of that pair, turned by a right angle.",
    ),
    "normal_form": (
        "A line has two normal forms, (r, alpha) and (-r, alpha + pi): pick the one with r >= 0.",
        "Flip the sign of r and turn alpha by pi when r is negative, then wrap alpha into (-pi, pi].",
    ),
    "jacobian": (
        "A column of the Jacobian is how (r, alpha) move when one range moves a little.",
        "For each beam, refit with that range nudged up by h and down by h, weights unchanged; the column is "
        "the difference of the two fits over 2h. Angles jump at +-pi: take their difference wrapped.",
    ),
    "ideal_weights": (
        "The best weights are one over the variance of what is minimised: each point's distance to the line.",
        "A range error sigma moves the point along its beam; only the part across the line counts, which "
        "shrinks with the angle between the beam and the line's normal.",
    ),
    "chord_distances": (
        "The distance of a point from a line through two points is a cross product over a length.",
        "Take the chord vector from the first to the last point and each point's vector from the first; "
        "the 2-D cross product of the two, in absolute value, over the chord's length. Whole columns, no loop.",
    ),
    "iepf": (
        "Split where the run bends most; repeat on the two halves until every piece is straight enough.",
        "Keep a stack of index ranges still to look at. A range too short for a line is dropped; otherwise "
        "find its point farthest from its chord (the protected points at both ends excluded) and either "
        "split there into two ranges or accept the range as a line. Push the halves so that the left one is "
        "looked at first: the lines come out in scan order.",
    ),
    "similar_lines": (
        "Compare the two lines' r and alpha; angles must be compared the short way round.",
        "Wrap the angle difference into (-pi, pi]. When it is larger than a right angle, the lines may be the "
        "same line with opposite normals: compare with the second line turned around instead.",
    ),
    "process_noise": (
        "Each axis moves on its own: x with vx, y with vy. Work out the 2 x 2 noise of one axis, then place it twice.",
        "For one axis the noise is q times the integral over the interval of the outer product of how a kick at "
        "time s moves position and velocity at the end (position by the time left, velocity by one). Put that "
        "block where x meets vx, and again where y meets vy; x and y share nothing.",
    ),
    "best_assignment": (
        "With a handful of rows, the cheapest pairing can be found by trying them all.",
        "Every pairing of rows to columns is a permutation of the column indices (the standard library's "
        "itertools makes them). Sum the costs along each, keep the smallest, and return its pairs by row.",
    ),
    "intersection": (
        "The corner is the solution of a 2 x 2 linear system: one equation per line.",
        "Write the system as a matrix of the normals' cosines and sines times (x, y) equals (r1, r2), and "
        "solve it by Cramer's rule; a determinant near 0 means parallel lines.",
    ),
    "is_core": (
        "A core point has at least min_pts points within eps, itself included.",
        "The neighbourhood of point i runs from index L[i] to index U[i], both included: count them.",
    ),
    "is_border": (
        "A border point is not core, but a core point is among its neighbours.",
        "For each point, look at the core flags from L[i] to U[i], both included; exclude the core points "
        "themselves. A cumulative sum of the core flags answers 'any core in this range' for all at once.",
    ),
    "triplet_direction": (
        "Fit a line to three points by total least squares: the direction of largest spread.",
        "Centre the points on their mean, form the three sums of squares and cross products, and take half "
        "the angle that their combination gives, as a direction between 0 and pi.",
    ),
    "wall_offsets": (
        "An offset is a signed distance across lines of the given direction through the origin.",
        "Project every point on the unit normal of the direction (the direction turned by a right angle).",
    ),
    "is_v_shaped": (
        "At a V corner the inscribed angle has a sharp minimum.",
        "Find the smallest angle, then check that the angles on both sides of it rise over a few neighbours.",
    ),
    "middle_ratio": (
        "How far does the middle point bulge out of the chord, compared with the chord's length?",
        "The signed distance of the middle point from the chord is a cross product over the chord's length; "
        "its sign says which side; make it positive on the viewpoint's side and divide by the chord length.",
    ),
    "radius_and_height": (
        "All points of an arc see its chord under the same angle (inscribed angle theorem).",
        "The centre lies on the chord's perpendicular bisector. In the right triangle formed by the centre, "
        "the chord's midpoint and one end, the angle at the centre follows from the mean inscribed angle; "
        "half the chord is the opposite side.",
    ),
    "pair_two_legs": (
        "Two legs are one person's when they stand close enough; the person stands between them.",
        "Measure the straight-line distance between the two centres in the plane; beyond the limit there is no "
        "person, otherwise the person's centre is the average of the two leg centres.",
    ),
    "config_for": (
        "Start from the default configuration and change two keys.",
        "Config().updated takes a dict of dotted keys; the split threshold is in metres.",
    ),
    "mean_per_scan": (
        "Count the features of that kind in every scan, then average.",
        "Each record of feats has one list per kind: getattr by name, len, then the mean.",
    ),
    "fewer_lines_share": (
        "Walk the two runs together, one scan at a time, and ask one yes-or-no question per scan.",
        "Pair each scan of a with the same scan of b; the answer is yes when b's list of lines is shorter than "
        "a's (equally long counts as no). The share is the mean of those answers, the yeses counting as one.",
    ),
    "normal_form_match": (
        "Both differences must be within their limits, limits included.",
        "Take the absolute range difference and the absolute wrapped angle difference and compare both.",
    ),
    "rates": (
        "Recall counts the walls found, precision the lines that are right: read the definitions above.",
        "TruePos is matched over truth; FalsePos is the unmatched share of the scored lines.",
    ),
    "three_beam_residual": (
        "On a straight wall the inverse ranges of three neighbours obey the identity above.",
        "Compare the neighbours' inverse ranges with the middle one times 2 cos(dtheta); turn that "
        "inverse-range residual back into metres near the middle range.",
    ),
    "ray_axis_error": (
        "Measure along the beam, not across the line: where does the ray itself cross the line?",
        "The ray's point at distance s satisfies the line's equation when s times the cosine of the angle "
        "between the beam and the normal equals r; the error is the measured range minus that s, and a ray "
        "at 90 degrees or more from the normal never reaches the line.",
    ),
    "compose_poses": (
        "b is given in a's frame: turn it by a's heading, then move it by a's position.",
        "Rotate b's translation by a's angle, add a's translation; the headings add; wrap the sum.",
    ),
    "pose_at": (
        "Interpolate linearly in time; the heading must go the short way round.",
        "The fraction u of the way from t0 to t1; x and y move by u of their change; the heading by u of the "
        "wrapped change, and the result is wrapped again.",
    ),
}

#: Per task whose solution is not in labkit.course_fallbacks: the labkit function the notebook goes on with.
SOLUTIONS: dict[str, str] = {
    "adaptive_threshold": "labkit.breakpoint_thresholds",
    "normal_form": "labkit.geometry.normalize_line",
    "iepf": "labkit.lines.iepf",
    "intersection": "labkit.geometry.intersect_lines",
    "is_v_shaped": "labkit.iav.is_v_corner",
    "middle_ratio": "labkit.iav.middle_point_offset",
}

#: The tasks whose solution was shown in this session.
SHOWN: set[str] = set()


def _solution(name: str):
    from . import course_fallbacks

    if name in SOLUTIONS:
        module, _, attribute = SOLUTIONS[name].rpartition(".")
        return getattr(importlib.import_module(module), attribute)
    return getattr(course_fallbacks, name)


def hint(name: str, level: int | str = 1) -> None:
    """Print hint ``level`` (1, 2, ...) for the task ``name``, or its solution for ``level="solution"``.

    Parameters
    ----------
    name : str
        The task: the name of the function the notebook asks for (``"iepf"``, ``"process_noise"``, ...).
    level : int or str, default 1
        The hint's number, from 1 to the task's number of hints, or ``"solution"``: the source of the
        function the notebook falls back on (the task's name is then added to ``SHOWN``).

    Raises
    ------
    KeyError
        For a name that is not a task; the message lists the tasks.
    ValueError
        For a level that is neither a hint's number nor ``"solution"``.
    """
    if name not in HINTS:
        raise KeyError(f"no task {name!r}; the tasks with hints are {sorted(HINTS)}")
    hints = HINTS[name]
    if level == "solution":
        SHOWN.add(name)
        function = _solution(name)
        print(f"{name}: the SOLUTION, shown because you asked for it (recorded in labkit.course_hints.SHOWN).\n"
              f"It is labkit's {function.__module__}.{function.__qualname__}, which the notebook uses while "
              f"your cell is a stub; write your own version before you run the check.\n")
        print(inspect.getsource(function))
        return
    if not isinstance(level, int) or not 1 <= level <= len(hints):
        raise ValueError(f"level must be 1 to {len(hints)} or 'solution', got {level!r}")
    more = (f' Next: hint("{name}", {level + 1}).' if level < len(hints)
            else f' Still stuck? hint("{name}", "solution") shows the solution (and says so).')
    print(f"{name}, hint {level} of {len(hints)}: {hints[level - 1]}{more}")
