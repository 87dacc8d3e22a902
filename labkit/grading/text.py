"""Text a student controls, made safe to show: in feedback, in ``grades.csv``, on the instructor's terminal.

A student writes exception messages, returns strings and names folders. Shown as they are, they can
rewrite a terminal (``ESC [ 2 J`` clears it, ``ESC [ 1 A`` moves up a line, so ``cat grades.csv``
shows a 0/10 row as 10/10), flood a report, or carry the hidden inputs out of the grader at full
precision. :func:`printable` strips escape sequences and control characters and cuts the length;
:func:`without_numbers` hides the numbers of a message about hidden inputs.
"""

from __future__ import annotations

import re

from .protocol import clean_text

__all__ = ["printable", "one_line", "without_numbers"]

#: ANSI/VT escape sequences: CSI (ESC [ ... final), OSC (ESC ] ... BEL or ESC \), and two-character ones.
_ESCAPES = re.compile(r"\x1b\[[0-?]*[ -/]*[@-~]|\x1b\][^\x07\x1b]*(?:\x07|\x1b\\)?|\x1b[@-_]|\x9b[0-?]*[ -/]*[@-~]")
#: Control characters (C0 but tab and newline, DEL, C1) and the bidirectional overrides that reorder what is shown.
_CONTROLS = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")
#: Numbers with a fraction or an exponent, and integers of five digits or more.
_NUMBERS = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+(?=[eE][-+]?\d))(?:[eE][-+]?\d+)?|\d{5,}")


def printable(text: object, limit: int = 2000) -> str:
    r"""``text`` with escape sequences and control characters removed, at most ``limit`` characters.

    Newlines and tabs are kept; a longer text is cut and ends with ``" [...]"``.

    Parameters
    ----------
    text : object
        Anything; not a str: its ``str()``.
    limit : int
        The most characters kept.

    Returns
    -------
    str
        The printable text.

    Examples
    --------
    >>> printable("score 0\x1b[1A\x1b[2K10/10")
    'score 010/10'
    >>> printable("x" * 10, limit=4)
    'xxxx [...]'
    """
    text = clean_text(str(text))
    text = _CONTROLS.sub("", _ESCAPES.sub("", text))
    return text if len(text) <= limit else text[:limit] + " [...]"


def one_line(text: object, limit: int = 500) -> str:
    """:func:`printable` on one line (line breaks and tabs become spaces): for a CSV field or a terminal row.

    Parameters
    ----------
    text : object
        Anything; not a str: its ``str()``.
    limit : int
        The most characters kept.

    Returns
    -------
    str
        The line.
    """
    return printable(" ".join(str(text).split()), limit)


def without_numbers(text: str) -> str:
    """``text`` with every number that has a fraction or an exponent, and every long integer, as ``#``.

    Long integers are those of five or more digits: what is left is what a message about inputs
    the student has not seen may show.

    Parameters
    ----------
    text : str
        A message.

    Returns
    -------
    str
        The message without those numbers.

    Examples
    --------
    >>> without_numbers("index 3 is out of bounds; got 0.1234 and 1e-9 at 1234567 (row 12)")
    'index 3 is out of bounds; got # and # at # (row 12)'
    """
    return _NUMBERS.sub("#", text)
