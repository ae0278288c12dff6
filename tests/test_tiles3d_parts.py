"""The 3D Tiles export's vectorised parts, on small hand-made inputs: exact values, and the same results as
the plain ways they replace."""
from __future__ import annotations

import numpy as np

from wit_plugin.tiles3d.store import _texcoords, aligned_decimals


def _chars(rows: list[str]) -> np.ndarray:
    """Rows as Arrow gives a text column (fixed-width bytes), in the (rows, width + 1) block ``_texcoords`` builds."""
    values = np.array([r.encode() for r in rows])
    chars = np.full((len(values), values.dtype.itemsize + 1), 32, dtype=np.uint8)
    chars[:, :-1] = np.frombuffer(values.tobytes(), dtype=np.uint8).reshape(len(values), -1)
    return chars


def test_aligned_decimals_are_the_correctly_rounded_values_of_the_texts():
    rng = np.random.default_rng(5)
    values = np.concatenate([rng.random(4000), rng.random(1000) * 9.9, [0.0, 1.0, 0.5, 9.999999999999]])
    texts = [f"{u:.12f}" for u in values]
    rows = [" ".join(texts[i:i + 8]) for i in range(0, 4000, 8)]
    numbers = aligned_decimals(_chars(rows))
    assert numbers.tolist() == [float(t) for t in texts[:4000]]  # float(): Python's correctly rounded parse
    hard = ["0.100000000000 0.300000000000", "0.000000000001 0.999999999999", "0.123456789012 0.987654321098"]
    assert aligned_decimals(_chars(hard)).tolist() == [0.1, 0.3, 1e-12, 0.999999999999, 0.123456789012,
                                                       0.987654321098]
    assert aligned_decimals(_chars(["12.5 10.25"])) is None  # numbers of two widths
    assert aligned_decimals(_chars(["2.50 1.25", "12.5 3.75"])) is None  # another row's columns
    assert aligned_decimals(_chars(["0.5 -0.5"])) is None  # a sign
    assert aligned_decimals(_chars(["1e-3 2e-3"])) is None  # an exponent
    assert aligned_decimals(_chars(["1234567890.1234567 0.0000000000000001"])) is None  # 17 digits


def test_texcoords_of_any_rows_are_those_of_the_plain_parse():
    """Rows the aligned parse does not take (roofs' rings of several lengths, other forms) give the same pairs
    and counts through C's parser; an odd count of numbers is refused."""
    aligned = ["0.250000000000 0.750000000000 0.500000000000 0.125000000000"] * 3
    mixed = ["0.1 0.2 0.3 0.4 0.1 0.2", "", "1 2", "-0.5 1e-1"]
    for rows in (aligned, mixed):
        uv, counts = _texcoords(np.array([r.encode() for r in rows]))
        numbers = [float(t) for r in rows for t in r.split()]
        assert uv.ravel().tolist() == numbers and counts.tolist() == [len(r.split()) // 2 for r in rows]
    try:
        _texcoords(np.array([b"0.1 0.2 0.3"]))
    except ValueError:
        pass
    else:
        raise AssertionError("an odd count of numbers was taken")
