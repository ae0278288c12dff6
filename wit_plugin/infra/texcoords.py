"""The texture table's columns (``infra.step_layers.TEX_*``) as numpy: texture coordinates and image names, read
in bulk by the 3D Tiles export, the metrics and the preview (one parser for all)."""
from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from .io import bulk_read


def parse_texcoords(texts: Sequence[str | None]) -> tuple[np.ndarray, np.ndarray]:
    """Texture-table ``uv`` texts ("u1 v1 u2 v2 …") → all pairs (k, 2) and the pair count of each text.

    One C parse for the whole batch; raises ``ValueError`` on a malformed text.
    """
    clean = [" ".join(t.split()) if t else "" for t in texts]
    counts = np.array([t.count(" ") + 1 if t else 0 for t in clean], dtype=np.int64)
    with warnings.catch_warnings():  # numpy's "could not be read to its end" (a word): a ValueError, as it soon is
        warnings.simplefilter("error", DeprecationWarning)
        try:
            flat = np.fromstring(" ".join(clean), sep=" ") if any(clean) else np.zeros(0)
        except DeprecationWarning as exc:
            raise ValueError("malformed texture coordinates") from exc
    if len(flat) != counts.sum() or np.any(counts % 2):
        raise ValueError("malformed texture coordinates")
    return flat.reshape(-1, 2), counts // 2


def parse_texcoord_column(column: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``parse_texcoords`` for a column; Arrow's fixed-width byte strings are parsed as one block
    (numbers and each row's count of them found with numpy, no Python loop per row)."""
    values = np.asarray(column)
    if values.dtype.kind != "S" or not len(values):
        return parse_texcoords(bulk_read.texts(values))
    chars = np.full((len(values), values.dtype.itemsize + 1), 32, dtype=np.uint8)  # a blank after each row
    chars[:, :-1] = np.frombuffer(values.tobytes(), dtype=np.uint8).reshape(len(values), -1)
    numbers = aligned_decimals(chars)
    if numbers is not None:
        return numbers.reshape(-1, 2), np.full(len(values), numbers.size // len(values) // 2, dtype=np.int64)
    blank = chars <= 32  # spaces and the NULs that pad a row to the column's width
    chars[blank] = 32
    starts = ~blank & np.concatenate([np.ones((len(chars), 1), dtype=bool), blank[:, :-1]], axis=1)
    counts = starts.sum(axis=1)
    flat = np.fromstring(chars.tobytes(), sep=" ") if counts.any() else np.zeros(0)
    if len(flat) != counts.sum() or np.any(counts % 2):
        raise ValueError("malformed texture coordinates")
    return flat.reshape(-1, 2), counts // 2


def aligned_decimals(chars: np.ndarray) -> np.ndarray | None:
    """The numbers written in the rows of ``chars`` (bytes, rows × columns, blanks ≤ 32), row after row, when
    every row writes as many in the same columns, all as ``digits.digits`` with the same count of decimals
    and at most 15 digits (the texture table's ``"%.12f"`` of TIN triangles' uv); else None.

    The values are those of ``float`` of the texts (correctly rounded): the digits make an integer below
    10^15, exact in float64, and one IEEE division by an exact power of ten rounds correctly. Column by
    column, with no search for where each number starts (C's parser took most of the texture table's staging).
    """
    if not len(chars):
        return None
    blank = chars[0] <= 32
    edges = np.flatnonzero(np.diff(~blank, prepend=False, append=False))
    starts, lengths = edges[0::2], edges[1::2] - edges[0::2]
    size = int(lengths[0]) if len(lengths) else 0
    if not 2 <= size <= 16 or (lengths != size).any() or (starts != np.arange(len(starts)) * (size + 1)).any():
        return None
    width = len(starts) * (size + 1)
    if (chars[:, width:] > 32).any():
        return None
    numbers = chars[:, :width].reshape(-1, size + 1)  # a number and its blank per row, whatever the layout of row 0
    point = int(np.argmax(chars[0, :size] == ord(".")))
    if chars[0, point] != ord(".") or not (numbers[:, point] == ord(".")).all() or (numbers[:, size] > 32).any():
        return None
    mantissa = np.zeros(len(numbers), dtype=np.int64)
    digit = np.empty(len(numbers), dtype=np.uint8)
    for column in range(size):  # (column by column: numpy's loops over a row of 15 bytes cost more than the work)
        if column != point:
            np.subtract(numbers[:, column], np.uint8(48), out=digit)  # anything but a digit wraps above 9
            if digit.max() > 9:
                return None
            mantissa *= 10  # (integer arithmetic: no BLAS threads to wait for)
            mantissa += digit
    return mantissa / float(10 ** (size - 1 - point))


def decimal_integers(column: np.ndarray) -> np.ndarray:
    """A column of decimal integer texts as int64, what ``astype(np.int64)`` gives: Arrow's fixed-width bytes of plain
    digits (NUL-padded) parsed column by column (numpy's parse of each text took a sixth of the texture table's
    staging); any other text through numpy's own parse, which raises ``ValueError`` on a non-number."""
    values = np.asarray(column)
    if values.dtype.kind != "S" or not len(values):
        return values.astype(np.int64)
    chars = np.frombuffer(values.tobytes(), dtype=np.uint8).reshape(len(values), -1)
    number = np.zeros(len(values), dtype=np.int64)
    ended = np.zeros(len(values), dtype=bool)  # past a row's digits: NULs only from there
    for position in range(chars.shape[1]):
        char = chars[:, position]
        digit = char - np.uint8(48)  # anything but a digit wraps above 9
        is_digit = digit <= 9
        if (position == 0 and not is_digit.all()) or (is_digit & ended).any() or (~is_digit & (char != 0)).any():
            return values.astype(np.int64)  # a sign, a blank, an empty text, a letter: numpy decides
        ended |= ~is_digit
        if ended.all():
            return number
        if position == 18:  # a 19th digit may not fit int64: numpy decides
            return values.astype(np.int64)
        number = np.where(is_digit, number * 10 + digit, number)
    return number


def unique_texts(column: np.ndarray) -> tuple[list[str], np.ndarray]:
    """The distinct texts of a column (decoded) and each row's index into them."""
    values = np.asarray(column)
    if values.dtype == object:
        values = np.array(bulk_read.texts(values))
    if not len(values):
        return [], np.zeros(0, dtype=np.int64)
    runs = np.flatnonzero(np.append(True, values[1:] != values[:-1]))  # (a column repeats its texts in runs)
    names, inverse = np.unique(values[runs], return_inverse=True)
    return bulk_read.texts(names), np.repeat(inverse, np.diff(np.append(runs, len(values))))
