"""Decompressing what can be decompressed of a damaged chunk (bz2, lz4, zstd).

A bag's compressed chunk that is garbled or cut off does not decompress as a whole. What is
left of it still does, in pieces:

- **bz2** compresses in independent blocks (up to 900 kB of input each), each starting with the
  48-bit magic ``0x314159265359`` at any bit position and carrying its own CRC. As ``bzip2recover``
  does, every block is cut out at its bit boundaries, wrapped as a stream of its own (stream
  header, the block, the end-of-stream magic ``0x177245385090`` and the block's CRC as the stream's
  CRC) and decompressed alone: a damaged block fails its CRC, every other block decodes.
- **lz4** frames and **zstd** frames decode front to back: the decoder is fed a little at a time
  and what it gave before it stopped is kept ("as far as the decoder gets").

:func:`salvage_chunk` returns the pieces (each a run of the chunk's decompressed bytes, in
order); a piece after a lost stretch begins in the middle of a record, so the caller walks it
from its first intact record on.
"""

from __future__ import annotations

import bz2

import lz4.frame

try:  # the same zstd rosbags itself uses
    from compression import zstd  # type: ignore[import-not-found]
except ImportError:  # Python < 3.14
    from backports import zstd  # type: ignore[import-not-found,no-redef]

__all__ = ["decompress", "salvage_chunk"]

_BLOCK_MAGIC = 0x314159265359
_END_MAGIC = 0x177245385090
_FEED = 16  # compressed bytes fed at a time to an lz4 or zstd decoder after a fault (a block decoded in
# the call that fails is lost with it)


def decompress(data, compression: str) -> bytes:
    """The whole chunk, decompressed (raises on any damage)."""
    data = bytes(data)
    if compression in ("", "none"):
        return data
    if compression == "bz2":
        return bz2.decompress(data)
    if compression == "lz4":
        return lz4.frame.decompress(data)
    if compression == "zstd":
        return zstd.decompress(data)
    raise ValueError(f"unknown chunk compression {compression!r}")


def salvage_chunk(data, compression: str) -> tuple[list[bytes], str]:
    """What can be decompressed of a damaged chunk: ``(pieces, what was lost)``.

    ``pieces`` are runs of decompressed bytes in order, with a lost stretch between two of them
    (and possibly after the last); the text says what could not be decoded.
    """
    data = bytes(data)
    if compression == "bz2":
        return _bz2_blocks(data)
    if compression == "lz4":
        return _front_to_back(lz4.frame.LZ4FrameDecompressor(), data, "lz4")
    if compression == "zstd":
        return _front_to_back(zstd.ZstdDecompressor(), data, "zstd")
    raise ValueError(f"unknown chunk compression {compression!r}")


def _front_to_back(decoder, data: bytes, name: str) -> tuple[list[bytes], str]:
    out = []
    for i in range(0, len(data), _FEED):
        try:
            out.append(decoder.decompress(data[i : i + _FEED]))
        except Exception as exc:  # noqa: BLE001 - each decoder has its own error type
            return [b"".join(out)], f"the {name} data does not decode past compressed byte ~{i} ({exc})"
        if getattr(decoder, "eof", False):
            break
    if not getattr(decoder, "eof", True):
        return [b"".join(out)], f"the {name} data is cut off"
    return [b"".join(out)], f"the {name} data decodes but holds garbled records"


# ---------------------------------------------------------------------------- bz2 blocks
# (bit shift, the whole bytes of the magic, bytes before them, and for a shift the (mask, value)
# checks of the partial first and last bytes)
_Pattern = tuple[int, bytes, int, tuple[tuple[int, int], tuple[int, int]] | None]


def _patterns(magic: int) -> list[_Pattern]:
    """For each bit shift s (the magic starting s bits into a byte): the bytes that lie wholly
    inside the magic, and how to check the partial bytes at either end."""
    found: list[_Pattern] = []
    for s in range(8):
        window = (magic << (8 - s)) if s else magic  # 56 bits (7 bytes) or, for s = 0, 48 bits
        size = 7 if s else 6
        raw = window.to_bytes(size, "big")
        if s == 0:
            found.append((0, raw, 0, None))
            continue
        head_mask = (1 << (8 - s)) - 1  # the low bits of the first byte belong to the magic
        tail_mask = (0xFF << (8 - s)) & 0xFF  # the high bits of the last byte do
        found.append((s, raw[1:6], 1, ((head_mask, raw[0] & head_mask), (tail_mask, raw[6] & tail_mask))))
    return found


_BLOCK_PATTERNS = _patterns(_BLOCK_MAGIC)
_END_PATTERNS = _patterns(_END_MAGIC)


def _find_bits(data: bytes, patterns: list[_Pattern]) -> list[int]:
    """Every bit position at which a 48-bit magic starts."""
    hits = []
    for s, middle, lead, edges in patterns:
        at = data.find(middle)
        while at >= 0:
            first = at - lead
            ok = first >= 0 and first + (7 if s else 6) <= len(data)
            if ok and edges is not None:
                head, tail = edges
                ok = (data[first] & head[0]) == head[1] and (data[first + 6] & tail[0]) == tail[1]
            if ok:
                hits.append(first * 8 + s)
            at = data.find(middle, at + 1)
    return sorted(hits)


def _bits(data: bytes, start: int, stop: int) -> int:
    """The bits ``[start, stop)`` of ``data`` as an integer."""
    first, last = start // 8, (stop + 7) // 8
    value = int.from_bytes(data[first:last], "big")
    value >>= last * 8 - stop
    return value & ((1 << (stop - start)) - 1)


def _bz2_blocks(data: bytes) -> tuple[list[bytes], str]:
    level = data[3:4] if data[:3] == b"BZh" and data[3:4].isdigit() else b"9"
    starts = _find_bits(data, _BLOCK_PATTERNS)
    ends = _find_bits(data, _END_PATTERNS)
    bounds = sorted(starts + ends + [len(data) * 8])
    pieces: list[bytes] = []
    lost = []
    current: list[bytes] = []
    for k, start in enumerate(starts):
        stop = next(b for b in bounds if b > start)
        if stop - start <= 80:
            continue
        crc = _bits(data, start + 48, start + 80)
        value = (_bits(data, start, stop) << 80) | (_END_MAGIC << 32) | crc
        n = stop - start + 80
        pad = -n % 8
        stream = b"BZh" + level + (value << pad).to_bytes((n + pad) // 8, "big")
        try:
            current.append(bz2.decompress(stream))
        except (OSError, ValueError, EOFError):
            lost.append(k + 1)
            if current:
                pieces.append(b"".join(current))
            current = []
    if current:
        pieces.append(b"".join(current))
    if not lost:
        return pieces, "the bz2 blocks decompress but the chunk holds garbled records"
    if len(starts) == 1:
        return pieces, "its one bz2 block does not decompress (bz2 loses a damaged block whole)"
    which = f"block {lost[0]}" if len(lost) == 1 else f"blocks {', '.join(map(str, lost))}"
    others = " (the others were recovered)" if len(lost) < len(starts) else ""
    return pieces, f"bz2 {which} of {len(starts)} do{'es' if len(lost) == 1 else ''} not decompress{others}"
