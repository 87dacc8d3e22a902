"""Fill-ins for the notebooks' "your turn" cells, one module per notebook (``nb01.py`` for
``01_*.ipynb``), each with ``FILLS = {stub cell id: Fill(...)}``.

``tests/test_notebooks.py`` runs every notebook once, cell by cell; at each stub cell (tagged
``your-turn``) it runs, before the check cell that follows (tagged ``your-turn-check``):

1. the planted typical mistake: the check must raise ``YourTurnError`` whose message
   contains ``hint``;
2. the correct fill-in: the check must pass (it prints "well done");
3. the stub as shipped: the check must say "not done yet" and the notebook goes on with
   labkit's version, exactly as a student who skipped the cell would see it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Fill:
    """A correct fill-in, a typical mistake, and a fragment of the hint the mistake must show."""

    correct: str
    mistake: str
    hint: str
