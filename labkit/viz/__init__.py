"""Viewers: matplotlib figures (:mod:`.plot`), rerun recordings (:mod:`.rr`) and
ipywidgets browsers (:mod:`.widgets`). Algorithms never import these modules.

Import the submodule you need (``from labkit.viz import plot``); importing
``labkit.viz.rr`` sets ``RERUN_NOTEBOOK_ASSET=serve-local`` before importing rerun, so
the notebook viewer works offline.
"""
