"""Where the fused passes of :func:`labkit.extract_features` keep what they take and hand back
(private: not part of labkit's API).

A :class:`labkit.Config`'s numbers go to the passes (:func:`labkit._iav_engine.stage_pass`,
:func:`labkit.lines._split_merge_engine.line_pass`) as two arrays, built once per Config
(:func:`labkit._pipeline_engine.plan_for`) with a scan's own written into a copy: a numba dispatch
checks the type of every argument, some 0.2 µs each, and a pass of thirty arguments paid 5 µs a
call for it. The floats' places are the ``F_*`` names, the integers' (and flags') the ``I_*``.
What the passes hand back is one float and one integer array each, rows of a fixed width per
feature (the ``*_F`` and ``*_I`` names): each array numba hands back to Python costs about a
microsecond.
"""

from __future__ import annotations

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
