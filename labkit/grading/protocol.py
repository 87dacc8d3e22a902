"""The grader's wire format: plain values between the trusted grader and the student's worker.

Both sides import this file: the trusted grader as ``labkit.grading.protocol``, the worker in the
sandbox as a top-level module ``protocol`` (it sees no labkit). It needs the standard library and
numpy only.

A message is one *frame*: a 4-byte big-endian length, then that many bytes of UTF-8 JSON. Values
inside a message are *tagged* JSON, so that nothing but plain data crosses:

==========================  =================================================================
Python value                 on the wire
==========================  =================================================================
``None``, ``bool``, ``str``  JSON ``null``, ``true``/``false``, string
``int``, ``float``           JSON number (``NaN``, ``Infinity`` and ``-Infinity`` as Python's
                             ``json`` writes them)
``list``                     JSON array
``tuple``                    ``{"T": [...]}``
``dict`` with ``str`` keys   ``{"D": [[key, value], ...]}``
numpy scalar                 ``{"S": dtype, "b": base64 of its bytes}``
``numpy.ndarray``            ``{"A": dtype, "s": shape, "b": base64 of its C-ordered bytes}``
==========================  =================================================================

``dtype`` is one of :data:`NUMERIC_DTYPES` (booleans, integers, floats and complex numbers in
this machine's byte order); no other array or scalar type can be sent. :func:`decode` is the
trusted side's only way in: it checks every tag, size and dtype, caps nesting and the number of
items, and builds fresh built-in objects (``np.frombuffer`` for arrays), so no object of the
student's -- no subclass, no ``__eq__``, no pickle -- ever reaches the grader. Anything else is a
:class:`ProtocolError`.
"""

from __future__ import annotations

import base64
import builtins
import json
import struct
from typing import Any

import numpy as np

__all__ = [
    "MAX_FRAME_BYTES",
    "MAX_ITEMS",
    "NUMERIC_DTYPES",
    "ProtocolError",
    "encode",
    "decode",
    "pack",
    "unpack",
    "exception_names",
    "rebuild_exception",
    "clean_text",
]

#: The largest frame either side accepts (bytes of JSON after the 4-byte header): the largest
#: answer an exercise needs (200 000 labels) is 2 MB.
MAX_FRAME_BYTES = 16 << 20
#: How deeply lists, tuples and dicts may nest.
MAX_DEPTH = 32
#: How many values (array elements count as one) a decoded message may hold.
MAX_ITEMS = 1 << 21
#: How many lists and objects a frame may hold, counted before it is parsed (so that a hostile
#: frame of ``[{},{},...]`` costs the trusted side no memory).
MAX_CONTAINERS = 1 << 18
#: Exception messages are cut to this many characters.
MAX_MESSAGE_CHARS = 4000
HEADER = struct.Struct(">I")

NUMERIC_DTYPES: dict[str, np.dtype] = {
    np.dtype(kind).str: np.dtype(kind)
    for kind in (
        np.bool_, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64,
        np.float16, np.float32, np.float64, np.complex64, np.complex128,
    )
}


class ProtocolError(Exception):
    """A message that breaks the wire format; the side that sent it is not to be believed any further."""


# ---------------------------------------------------------------------------- encoding
def _numeric(value: Any, what: str) -> np.ndarray:
    """``value`` as a plain C-ordered ndarray of a dtype in :data:`NUMERIC_DTYPES`, or TypeError."""
    array = np.asarray(value).view(np.ndarray)
    if array.dtype.str not in NUMERIC_DTYPES:
        native = array.dtype.newbyteorder("=") if array.dtype.kind in "biufc" else None
        if native is None or native.str not in NUMERIC_DTYPES:
            raise TypeError(
                f"a {what} of dtype {array.dtype} cannot be graded: use numbers (bool, int, float or complex)"
            )
        array = array.astype(native)
    return array if array.flags.c_contiguous else array.copy(order="C")


def encode(value: Any, _depth: int = 0, _budget: list[int] | None = None) -> Any:
    """``value`` as tagged JSON data (see the module's table); TypeError for anything else.

    Subclasses of the built-in types are sent as their base type, ndarray subclasses as plain
    arrays: only their data crosses. A value that could not fit in one frame -- more than
    :data:`MAX_ITEMS` values, or arrays and strings longer than :data:`MAX_FRAME_BYTES` once
    encoded -- is refused as soon as it is met, before any of it is copied: a student's function
    that returns 160 MB of zeros gets its TypeError at once instead of spending its time limit
    on base64.

    Parameters
    ----------
    value : object
        Tuples, lists, dicts, numbers, strings, None and numeric ndarrays, nested.
    _depth : int
        Internal: the nesting depth of ``value`` (callers leave it out).
    _budget : list of int or None
        Internal: the values and bytes still allowed (callers leave it out).

    Returns
    -------
    object
        The tagged JSON data, ready for :func:`pack`.

    Examples
    --------
    >>> encode((1, [2.5, None], {"k": True}))
    {'T': [1, [2.5, None], {'D': [['k', True]]}]}
    >>> encode(np.arange(2, dtype=np.int8))
    {'A': '|i1', 's': [2], 'b': 'AAE='}
    """
    if _depth > MAX_DEPTH:
        raise TypeError(f"values nest more than {MAX_DEPTH} levels deep")
    if _budget is None:
        _budget = [MAX_ITEMS, MAX_FRAME_BYTES]
    _budget[0] -= 1
    if _budget[0] < 0:
        raise TypeError(f"more than {MAX_ITEMS} values in one answer")
    if isinstance(value, (np.ndarray, np.generic, str)):  # sizes of the plain data, whatever a subclass says
        size = str.__len__(value) if isinstance(value, str) else np.asarray(value).view(np.ndarray).nbytes
        _budget[1] -= size if isinstance(value, str) else 4 * -(-size // 3)
        if _budget[1] < 0:
            raise TypeError(f"the answer is larger than the {MAX_FRAME_BYTES} bytes one message may hold")
    if value is None or type(value) in (bool, int, float, str):
        return value
    if isinstance(value, np.ndarray):
        array = _numeric(value, "numpy array")
        return {"A": array.dtype.str, "s": list(array.shape), "b": base64.b64encode(array.tobytes()).decode("ascii")}
    if isinstance(value, np.generic):
        array = _numeric(value, "numpy scalar")
        return {"S": array.dtype.str, "b": base64.b64encode(array.tobytes()).decode("ascii")}
    if isinstance(value, bool):
        return bool(value)
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value)
    if isinstance(value, str):
        return str(value)
    if isinstance(value, list):
        return [encode(item, _depth + 1, _budget) for item in value]
    if isinstance(value, tuple):
        return {"T": [encode(item, _depth + 1, _budget) for item in value]}
    if isinstance(value, dict):
        if not all(isinstance(key, str) for key in value):
            raise TypeError("only dicts with str keys can be graded")
        return {"D": [[str(key), encode(item, _depth + 1, _budget)] for key, item in value.items()]}
    raise TypeError(
        f"a {type(value).__name__} cannot be graded: return numbers, strings, None, lists, tuples, dicts"
        " or numpy arrays of numbers"
    )


# ---------------------------------------------------------------------------- decoding
def decode(data: Any) -> Any:
    """Build plain Python and numpy values from tagged JSON data (as :func:`json.loads` returns it).

    Parameters
    ----------
    data : object
        Tagged JSON data, as :func:`encode` makes it.

    Returns
    -------
    object
        The values: tuples, lists, dicts, numbers, strings, None and numeric ndarrays.

    Raises
    ------
    ProtocolError
        For an unknown tag, a dtype outside :data:`NUMERIC_DTYPES`, a buffer whose size does not
        match its shape, nesting deeper than ``MAX_DEPTH`` or more than :data:`MAX_ITEMS`
        values.

    Examples
    --------
    >>> decode({"T": [1, {"A": "<f8", "s": [1], "b": "AAAAAAAA8D8="}]})
    (1, array([1.]))
    >>> decode({"A": "|O", "s": [1], "b": ""})
    Traceback (most recent call last):
    ...
    labkit.grading.protocol.ProtocolError: dtype '|O' is not a numeric dtype
    """
    budget = [MAX_ITEMS]
    return _decode(data, 0, budget)


def _decode(data: Any, depth: int, budget: list[int]) -> Any:
    budget[0] -= 1
    if budget[0] < 0:
        raise ProtocolError(f"more than {MAX_ITEMS} values in one message")
    if depth > MAX_DEPTH:
        raise ProtocolError(f"values nest more than {MAX_DEPTH} levels deep")
    kind = type(data)
    if kind is str:
        return clean_text(data)
    if data is None or kind in (bool, int, float):
        return data
    if kind is list:
        return [_decode(item, depth + 1, budget) for item in data]
    if kind is not dict:
        raise ProtocolError(f"unexpected JSON value of type {kind.__name__}")
    keys = sorted(data)
    if keys == ["T"] and type(data["T"]) is list:
        return tuple(_decode(item, depth + 1, budget) for item in data["T"])
    if keys == ["D"] and type(data["D"]) is list:
        result = {}
        for pair in data["D"]:
            if type(pair) is not list or len(pair) != 2 or type(pair[0]) is not str:
                raise ProtocolError("a dict entry must be [str key, value]")
            result[pair[0]] = _decode(pair[1], depth + 1, budget)
        return result
    if keys == ["A", "b", "s"]:
        shape = data["s"]
        if type(shape) is not list or len(shape) > MAX_DEPTH or any(type(n) is not int or n < 0 for n in shape):
            raise ProtocolError(f"bad array shape {shape!r}")
        array = _buffer(data["A"], data["b"], shape)
        budget[0] -= 1
        return array
    if keys == ["S", "b"]:
        return _buffer(data["S"], data["b"], [])[()]
    raise ProtocolError(f"unknown tagged value with keys {keys[:5]}")


def _buffer(dtype_name: Any, text: Any, shape: list[int]) -> np.ndarray:
    if type(dtype_name) is not str or dtype_name not in NUMERIC_DTYPES:
        raise ProtocolError(f"dtype {dtype_name!r} is not a numeric dtype")
    if type(text) is not str:
        raise ProtocolError("array data must be a base64 string")
    dtype = NUMERIC_DTYPES[dtype_name]
    count = 1
    for n in shape:
        if n > MAX_FRAME_BYTES:
            raise ProtocolError(f"an array dimension of {n} is larger than any frame")
        count *= n
    if count * dtype.itemsize != (len(text) // 4) * 3 - text[-2:].count("="):
        raise ProtocolError(f"array data does not hold {count} values of {dtype}")
    try:
        raw = base64.b64decode(text, validate=True)
    except ValueError as error:
        raise ProtocolError(f"bad base64 array data: {error}") from None
    try:
        return np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
    except ValueError as error:  # numpy refuses the shape (too many dimensions, too big)
        raise ProtocolError(f"bad array shape {shape!r}: {error}") from None


# ---------------------------------------------------------------------------- frames
def pack(message: dict) -> bytes:
    """One frame: the 4-byte length, then ``message`` as compact JSON (its values already encoded).

    A frame longer than :data:`MAX_FRAME_BYTES` raises ``TypeError``.

    Parameters
    ----------
    message : dict
        The message, its values encoded (:func:`encode`).

    Returns
    -------
    bytes
        The frame.
    """
    body = json.dumps(message, separators=(",", ":"), allow_nan=True).encode("utf-8")
    if len(body) > MAX_FRAME_BYTES:
        raise TypeError(f"the message is {len(body)} bytes, more than the {MAX_FRAME_BYTES} allowed")
    return HEADER.pack(len(body)) + body


def frame_length(header: bytes) -> int:
    """The body length a frame header announces; ProtocolError beyond :data:`MAX_FRAME_BYTES`."""
    (length,) = HEADER.unpack(header)
    if length > MAX_FRAME_BYTES:
        raise ProtocolError(f"a frame of {length} bytes is larger than the {MAX_FRAME_BYTES} allowed")
    return length


def unpack(body: bytes) -> dict:
    """The JSON object of a frame's body; ProtocolError for anything that is not one.

    Parameters
    ----------
    body : bytes
        The frame's body (without its length).

    Returns
    -------
    dict
        The message.
    """
    if body.count(b"[") + body.count(b"{") > MAX_CONTAINERS:
        raise ProtocolError(f"a frame with more than {MAX_CONTAINERS} lists and objects")
    try:
        message = json.loads(body.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as error:
        raise ProtocolError(f"a frame that is not JSON: {str(error)[:200]}") from None
    if type(message) is not dict:
        raise ProtocolError("a frame must hold a JSON object")
    return message


def clean_text(text: str) -> str:
    r"""``text`` with every character UTF-8 cannot hold (a lone surrogate such as ``"\ud800"``) as ``?``.

    JSON can carry them and Python strings can hold them, but no file, CSV or database the grader
    writes can: one such string must not stop the class.

    Parameters
    ----------
    text : str
        Any string.

    Returns
    -------
    str
        The string, every character UTF-8 cannot encode replaced by ``?``.

    Examples
    --------
    >>> clean_text("half an emoji: \ud83d")
    'half an emoji: ?'
    """
    if text.isascii():
        return text
    return text.encode("utf-8", "replace").decode("utf-8")


# ---------------------------------------------------------------------------- exceptions
def _constructible(cls: type) -> bool:
    try:
        cls("message")
    except Exception:  # noqa: BLE001 -- e.g. UnicodeDecodeError wants five arguments
        return False
    return True


#: Built-in exception classes the trusted side rebuilds by name (only those taking one message).
BUILTIN_EXCEPTIONS: dict[str, type[Exception]] = {
    name: cls
    for name, cls in vars(builtins).items()
    if isinstance(cls, type) and issubclass(cls, Exception) and _constructible(cls)
}


def exception_names(error: BaseException) -> list[str]:
    """Names of the built-in classes in ``type(error).__mro__``, most specific first.

    Parameters
    ----------
    error : BaseException
        The exception.

    Returns
    -------
    list of str
        The names of its built-in exception classes (a student's own classes left out).
    """
    return [cls.__name__ for cls in type(error).__mro__ if cls.__module__ == "builtins"][:16]


def rebuild_exception(names: Any, message: Any) -> Exception:
    """A fresh built-in exception: the first of ``names`` in ``BUILTIN_EXCEPTIONS``, else RuntimeError.

    Parameters
    ----------
    names : object
        The class names sent (:func:`exception_names`); anything else than a list of str raises
        :class:`ProtocolError`.
    message : object
        The message sent; anything else than a str raises :class:`ProtocolError`.

    Returns
    -------
    Exception
        The exception, never a class of the student's.

    Examples
    --------
    >>> rebuild_exception(["MyError", "ValueError", "Exception"], "bad")
    ValueError('bad')
    >>> rebuild_exception(["KeyboardInterrupt", "BaseException"], "stop")
    RuntimeError('KeyboardInterrupt: stop')
    """
    if type(names) is not list or not all(type(name) is str for name in names):
        raise ProtocolError("exception names must be a list of str")
    if type(message) is not str:
        raise ProtocolError("an exception message must be a str")
    message = clean_text(message[:MAX_MESSAGE_CHARS])
    for name in names[:16]:
        cls = BUILTIN_EXCEPTIONS.get(name)
        if cls is not None:
            return cls(message)
    first = names[0] if names else "an exception"
    return RuntimeError(f"{first}: {message}"[:MAX_MESSAGE_CHARS])
