"""Whether labkit runs its numba-compiled engines (private: not part of labkit's API).

``LABKIT_NO_JIT=1`` in the environment turns them off: :func:`labkit.lines.split_and_merge`,
:func:`labkit.segment_labels`, the noise estimate and the IAV detectors' tests
(:mod:`labkit._iav_engine`) run their readable numpy code, and :func:`labkit.extract_features` its
stages one detector at a time instead of :mod:`labkit._pipeline_engine` (the same features, slower); numba
is not imported at all -- for a machine where numba will not install or compile, or to step
through the readable code in a debugger.
"""

from __future__ import annotations

import os

#: False when ``$LABKIT_NO_JIT`` is set to anything but "" or "0" (read once, at import).
ENABLED = os.environ.get("LABKIT_NO_JIT", "").strip() in ("", "0")
