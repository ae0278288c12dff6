"""A minimal ESRI Shapefile writer (.shp/.shx/.dbf/.prj) that writes geometry exactly as given.

OGR repairs rings on write (closes them, fixes orientation), so it cannot reproduce the defects
that real national data carries. This writer follows the ESRI shapefile specification byte for
byte and never touches coordinates: the caller decides ring order and closure. DBF text is
encoded with the caller's code page and the language-driver byte is left 0 with no ``.cpg``,
as in the road-name-address downloads (juso.go.kr).
"""
from __future__ import annotations

import datetime
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..infra.errors import InputError

SHP_POLYLINE = 3
SHP_POLYGON = 5

Parts = Sequence[np.ndarray]
"""One feature: its rings (polygon) or parts (polyline), each an (n, 2) float array."""


@dataclass(frozen=True)
class Field:
    """A dBASE III field: ``type`` is 'C' (text, ``width`` bytes) or 'N' (number)."""

    name: str
    type: str
    width: int
    decimals: int = 0


def write_shapefile(base: Path, shape_type: int, geometries: Sequence[Parts], fields: Sequence[Field],
                    columns: Mapping[str, Sequence[Any]], prj_wkt: str, encoding: str = "cp949",
                    dbf_date: datetime.date = datetime.date(2022, 12, 31)) -> None:
    """Write ``base``.shp/.shx/.dbf/.prj; ``columns`` maps field names to one value per feature.

    A ``None`` value is written blank (read back as NULL). ``dbf_date`` is fixed rather than
    today so that the same input gives byte-identical files.
    """
    base = Path(base)
    shp, shx = _shp_bytes(shape_type, geometries)
    base.with_suffix(".shp").write_bytes(shp)
    base.with_suffix(".shx").write_bytes(shx)
    base.with_suffix(".dbf").write_bytes(_dbf_bytes(fields, columns, len(geometries), encoding, dbf_date))
    base.with_suffix(".prj").write_text(prj_wkt, encoding="ascii")


def _shp_bytes(shape_type: int, geometries: Sequence[Parts]) -> tuple[bytes, bytes]:
    records, index = [], []
    offset = 50  # in 16-bit words, after the 100-byte header
    boxes = []
    for number, parts in enumerate(geometries, start=1):
        points = np.concatenate(parts).astype("<f8")
        box = (points[:, 0].min(), points[:, 1].min(), points[:, 0].max(), points[:, 1].max())
        boxes.append(box)
        starts = np.cumsum([0] + [len(p) for p in parts[:-1]]).astype("<i4")
        content = (struct.pack("<i4d2i", shape_type, *box, len(parts), len(points))
                   + starts.tobytes() + points.tobytes())
        words = len(content) // 2
        records.append(struct.pack(">2i", number, words) + content)
        index.append(struct.pack(">2i", offset, words))
        offset += 4 + words
    full = np.array(boxes) if boxes else np.zeros((1, 4))
    bbox = (full[:, 0].min(), full[:, 1].min(), full[:, 2].max(), full[:, 3].max())

    def header(length_words: int) -> bytes:
        return (struct.pack(">7i", 9994, 0, 0, 0, 0, 0, length_words)
                + struct.pack("<2i4d4d", 1000, shape_type, *bbox, 0.0, 0.0, 0.0, 0.0))

    shp = header(offset) + b"".join(records)
    shx = header(50 + 4 * len(index)) + b"".join(index)
    return shp, shx


def _dbf_bytes(fields: Sequence[Field], columns: Mapping[str, Sequence[Any]], count: int, encoding: str,
               dbf_date: datetime.date) -> bytes:
    record_len = 1 + sum(f.width for f in fields)
    header_len = 32 + 32 * len(fields) + 1
    head = struct.pack("<B3BIHH20x", 0x03, dbf_date.year - 1900, dbf_date.month, dbf_date.day,
                       count, header_len, record_len)  # byte 29 (language driver) stays 0
    for f in fields:
        head += struct.pack("<11sc4xBB14x", f.name.encode("ascii"), f.type.encode("ascii"), f.width, f.decimals)
    head += b"\r"
    table = np.empty(count, dtype=[("deleted", "S1")] + [(f.name, f"S{f.width}") for f in fields])
    table["deleted"] = b" "
    for f in fields:
        values = columns[f.name]
        if len(values) != count:
            raise InputError(f"field {f.name} has {len(values)} values for {count} features")
        table[f.name] = [_cell(f, v, encoding) for v in values]
    return head + table.tobytes() + b"\x1a"


def _cell(field: Field, value: Any, encoding: str) -> bytes:
    """One field value as exactly ``field.width`` bytes (text left-, numbers right-aligned)."""
    if value is None:
        return b" " * field.width
    if field.type == "C":
        raw = str(value).encode(encoding)
    elif field.decimals:
        raw = f"{value:{field.width}.{field.decimals}f}".encode("ascii")
    else:
        raw = f"{int(value):{field.width}d}".encode("ascii")
    if len(raw) > field.width:
        raise InputError(f"value {value!r} does not fit field {field.name} ({field.width} bytes)")
    return raw.ljust(field.width) if field.type == "C" else raw.rjust(field.width)
