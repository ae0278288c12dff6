"""NGII map-sheet numbers (도엽번호): digits ↔ degree bounds ↔ projected footprint.

NGII orthoimage tiles arrive without georeferencing; their file names carry the sheet number,
which fixes the sheet's bounds in degrees on Korea 2000 (EPSG:4737). This module turns a number
into bounds, finds the sheet containing a point (the inverse), and projects a sheet's corners
into the target CRS.

The numbering:

* digits 1–2: latitude of the south edge of a 1°×1° block, 32–43: the peninsula and islands span
  about 33.1–43.0°N, and the real NGII 1:5,000 index also has one sheet at 32.1°N (the Ieodo
  ocean research station, 125.18°E);
* digit 3: last digit of the west-edge longitude. Korea spans 124–131°E (Baengnyeongdo 124.6°E,
  Dokdo 131.9°E), so digits 4–9 mean 124–129°E and 0, 1 mean 130°E and 131°E (Ulleungdo and
  Dokdo sheets start ``370``/``371``). Digits 2 and 3 are rejected: 122/123°E and 132/133°E hold
  no Korean territory, so such a number is a misread name rather than a sheet;
* then each scale splits its parent cell into k×k cells numbered row by row from the north-west
  cell eastwards, then southwards:

  =========  ======  ==============================  ==  =========
  scale      digits  built as                        k   cell size
  =========  ======  ==============================  ==  =========
  1:50,000   5       block + 01–16                   4   0.25°
  1:25,000   6       1:50,000 + 1–4                  2   0.125°
  1:10,000   7       1:50,000 + 01–25                5   0.05°
  1:5,000    8       1:50,000 + 001–100              10  0.025°
  1:1,000    9       1:10,000 + 00–99                10  0.005°
  =========  ======  ==============================  ==  =========

1:1,000 decision: a 10×10 split needs 100 numbers but the numbering gives it two digits, so it cannot
be numbered 1–100 like the other scales. We read the two digits as 00–99 counted from 0 in the
same row-major order, i.e. the first digit is the row from the north (0–9) and the second the
column from the west (0–9): ``00`` is the north-west cell, ``09`` the north-east, ``99`` the
south-east. The cell size fits NGII's data (a public copy of the NGII 1:1,000 index has 441,354
sheets, 25 per 1:5,000 sheet, i.e. 0.005° cells), but no source we could reach shows the digit
order; if NGII numbers them 01–99 plus ``00`` for the 100th cell, only the 1:1,000 entry of
``_LEVELS`` and its cell-number mapping change.

All cell edges are whole multiples of 1/200°, so bounds are computed from integer grid indices and
are exact to the last bit of a float (no accumulated rounding from repeated subdivision).
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass

import numpy as np
import shapely
from pyproj import Transformer
from pyproj.exceptions import CRSError, ProjError

from .errors import InputError

SCALES = (50000, 25000, 10000, 5000, 1000)

_UNITS_PER_DEGREE = 200
# scale -> (parent scale, or None for the 1° block; k; suffix digits; number of the first cell)
_LEVELS = {
    50000: (None, 4, 2, 1),
    25000: (50000, 2, 1, 1),
    10000: (50000, 5, 2, 1),
    5000: (50000, 10, 3, 1),
    1000: (10000, 10, 2, 0),
}
_SCALE_BY_DIGITS = {5: 50000, 6: 25000, 7: 10000, 8: 5000, 9: 1000}
_LAT_BLOCKS = range(32, 44)
_LON_BY_DIGIT = {4: 124, 5: 125, 6: 126, 7: 127, 8: 128, 9: 129, 0: 130, 1: 131}
_DIGIT_BY_LON = {lon: digit for digit, lon in _LON_BY_DIGIT.items()}
_EPS = 1e-9  # in cell units: a point on a cell edge belongs to the cell east/north of it


@dataclass(frozen=True)
class MapSheet:
    """One NGII sheet: its number, scale denominator and degree bounds on the sheet datum."""

    number: str
    scale: int
    west: float
    south: float
    east: float
    north: float


def _cell_units(scale: int) -> int:
    """Cell size in 1/200° (the block is 200)."""
    parent, k, _, _ = _LEVELS[scale]
    return (_UNITS_PER_DEGREE if parent is None else _cell_units(parent)) // k


def _scale_label(scale: int) -> str:
    return f"1:{scale:,}"


def _make_sheet(number: str, scale: int, col: int, row: int) -> MapSheet:
    """Sheet from global grid indices: ``col`` eastwards from 0°E, ``row`` northwards from 0°N."""
    size = _cell_units(scale)
    u = _UNITS_PER_DEGREE
    return MapSheet(number, scale, col * size / u, row * size / u, (col + 1) * size / u, (row + 1) * size / u)


def _parse_indices(digits: str, scale: int) -> tuple[int, int]:
    """Global (col, row) grid indices of the sheet ``digits`` at ``scale``; InputError if invalid."""
    parent, k, width, first = _LEVELS[scale]
    if parent is None:
        col, row = _parse_block(digits)
        suffix = digits[3:5]
    else:
        col, row = _parse_indices(digits[: len(digits) - width], parent)
        suffix = digits[len(digits) - width:]
    n = int(suffix)
    last = first + k * k - 1
    if not first <= n <= last:
        raise InputError(f"cell {suffix} out of range {first:0{width}d}–{last:0{width}d} at {_scale_label(scale)}")
    r, c = divmod(n - first, k)
    return col * k + c, row * k + (k - 1 - r)


def _parse_block(digits: str) -> tuple[int, int]:
    """Global (col, row) of the 1° block named by the first three digits."""
    lat, lon_digit = int(digits[:2]), int(digits[2])
    if lat not in _LAT_BLOCKS:
        raise InputError(
            f"latitude block {lat}°N is outside Korea "
            f"({_LAT_BLOCKS.start}–{_LAT_BLOCKS.stop - 1}°N)")
    if lon_digit not in _LON_BY_DIGIT:
        raise InputError(
            f"longitude digit {lon_digit} (12{lon_digit}°E or 13{lon_digit}°E) is outside "
            "Korea (124–131°E: digits 4–9 and 0–1)")
    return _LON_BY_DIGIT[lon_digit], lat


def parse_sheet_number(digits: str) -> MapSheet:
    """The sheet for a 5–9 digit NGII number; InputError saying why if it is not a valid number."""
    if not digits or not re.fullmatch(r"[0-9]+", digits):
        raise InputError(f"'{digits}' is not a sheet number: it must consist of the digits 0–9 only")
    scale = _SCALE_BY_DIGITS.get(len(digits))
    if scale is None:
        raise InputError(
            f"'{digits}' has {len(digits)} digits; a sheet number has 5 (1:50,000), 6 (1:25,000), "
            "7 (1:10,000), 8 (1:5,000) or 9 (1:1,000) digits")
    try:
        col, row = _parse_indices(digits, scale)
    except InputError as exc:
        raise InputError(f"'{digits}' ({_scale_label(scale)}): {exc}") from None
    return _make_sheet(digits, scale, col, row)


def find_sheet_in_name(name: str) -> MapSheet:
    """The sheet whose number appears in a file name, e.g. ``(B060)정사영상_2022_37713074.tif``.

    Every maximal run of ASCII digits of length 5–9 is a candidate (shorter runs such as a year or
    a product code, and longer runs, cannot be sheet numbers). Exactly one distinct valid number
    must remain; otherwise InputError says why, never guessing between two sheets.
    """
    runs = [m.group() for m in re.finditer(r"[0-9]+", name)]
    candidates = [r for r in runs if 5 <= len(r) <= 9]
    if not candidates:
        raise InputError(f"no 5–9 digit sheet number in '{name}'")
    valid: dict[str, MapSheet] = {}
    reasons = []
    for digits in candidates:
        try:
            valid.setdefault(digits, parse_sheet_number(digits))
        except InputError as exc:
            reasons.append(str(exc))
    if len(valid) > 1:
        raise InputError(f"ambiguous sheet number in '{name}': {', '.join(valid)} are all valid")
    if not valid:
        raise InputError(f"no valid sheet number in '{name}': {'; '.join(reasons)}")
    return next(iter(valid.values()))


def _check_scale(scale: int) -> None:
    if scale not in _LEVELS:
        choices = ", ".join(map(_scale_label, SCALES))
        raise InputError(f"scale 1:{scale} is not an NGII sheet scale; use one of {choices}")


def _sheet_from_indices(col: int, row: int, scale: int) -> MapSheet:
    """Build the number of the cell at global indices (col, row) by walking up to the block."""
    parent, k, width, first = _LEVELS[scale]
    if parent is None:
        lon, lat = col // k, row // k
        digit = _DIGIT_BY_LON.get(lon)
        if lat not in _LAT_BLOCKS or digit is None:
            raise InputError(
                f"cell at {lon}–{lon + 1}°E, {lat}–{lat + 1}°N is outside the NGII sheet grid for Korea "
                f"(124–132°E, {_LAT_BLOCKS.start}–{_LAT_BLOCKS.stop}°N)")
        prefix = f"{lat}{digit}"
    else:
        prefix = _sheet_from_indices(col // k, row // k, parent).number
    c, r = col % k, k - 1 - row % k
    return _make_sheet(f"{prefix}{r * k + c + first:0{width}d}", scale, col, row)


def sheet_at(lon: float, lat: float, scale: int = 5000) -> MapSheet:
    """The sheet containing a point given in degrees on the sheet datum (edges go east/north)."""
    _check_scale(scale)
    if not (math.isfinite(lon) and math.isfinite(lat)):
        raise InputError(f"point ({lon}, {lat}) is not a finite longitude/latitude")
    per_cell = _UNITS_PER_DEGREE / _cell_units(scale)
    return _sheet_from_indices(math.floor(lon * per_cell + _EPS), math.floor(lat * per_cell + _EPS), scale)


def sheets_at(lon: np.ndarray, lat: np.ndarray, scale: int = 5000) -> list[str]:
    """``sheet_at(lon[i], lat[i], scale).number`` for many points at once (each distinct cell built once)."""
    _check_scale(scale)
    lon, lat = np.asarray(lon, dtype=np.float64), np.asarray(lat, dtype=np.float64)
    if not (np.isfinite(lon).all() and np.isfinite(lat).all()):
        raise InputError("points with infinite or NaN longitude/latitude have no sheet")
    per_cell = _UNITS_PER_DEGREE / _cell_units(scale)
    cells = np.column_stack([np.floor(lon * per_cell + _EPS), np.floor(lat * per_cell + _EPS)]).astype(np.int64)
    unique, inverse = np.unique(cells, axis=0, return_inverse=True)
    numbers = [_sheet_from_indices(int(c), int(r), scale).number for c, r in unique]
    return [numbers[k] for k in inverse.ravel()]


def sheets_covering(west: float, south: float, east: float, north: float, scale: int = 5000) -> list[MapSheet]:
    """All sheets overlapping a degree box, north to south then west to east (reading order).

    A box edge lying exactly on a sheet edge does not pull in the neighbouring sheet.
    """
    _check_scale(scale)
    if not all(map(math.isfinite, (west, south, east, north))) or west > east or south > north:
        raise InputError(f"invalid box west={west}, south={south}, east={east}, north={north}")
    per_cell = _UNITS_PER_DEGREE / _cell_units(scale)
    c0, r0 = math.floor(west * per_cell + _EPS), math.floor(south * per_cell + _EPS)
    c1 = max(c0, math.ceil(east * per_cell - _EPS) - 1)
    r1 = max(r0, math.ceil(north * per_cell - _EPS) - 1)
    return [_sheet_from_indices(c, r, scale) for r in range(r1, r0 - 1, -1) for c in range(c0, c1 + 1)]


@functools.lru_cache(maxsize=32)
def _transformer(source_crs: str, target_crs: str) -> Transformer:
    """Cached: building a transformer costs far more than using it (pyproj ≥ 3.1 is thread-safe)."""
    try:
        return Transformer.from_crs(source_crs, target_crs, always_xy=True)
    except (CRSError, ProjError) as exc:
        raise InputError(f"cannot transform from {source_crs} to {target_crs}: {exc}") from exc


def projected_envelope(sheet: MapSheet, target_crs: str = "EPSG:5186", source_crs: str = "EPSG:4737",
                       margin: float = 0.0) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of the sheet's four projected corners, grown by ``margin``.

    This is how NGII cuts its orthoimages: the envelope of the corners (not of the curved edges)
    plus about 50 m, axis-aligned in the target CRS.
    """
    xs, ys = _transformer(source_crs, target_crs).transform(
        [sheet.west, sheet.east, sheet.east, sheet.west], [sheet.south, sheet.south, sheet.north, sheet.north])
    if not all(map(math.isfinite, (*xs, *ys))):
        raise InputError(f"sheet {sheet.number} cannot be projected to {target_crs}")
    return min(xs) - margin, min(ys) - margin, max(xs) + margin, max(ys) + margin


def sheet_polygon(sheet: MapSheet, target_crs: str, sheet_crs: str = "EPSG:4737") -> shapely.Polygon:
    """The sheet's corners (NW, NE, SE, SW) projected to ``target_crs``, joined by straight edges:
    neighbouring sheets share their corners exactly, so the polygons partition the plane."""
    to_target = Transformer.from_crs(sheet_crs, target_crs, always_xy=True)
    xs, ys = to_target.transform([sheet.west, sheet.east, sheet.east, sheet.west],
                                 [sheet.north, sheet.north, sheet.south, sheet.south])
    return shapely.Polygon(list(zip(xs, ys))[::-1])  # counter-clockwise: SW, SE, NE, NW


def sheets_overlapping(area: shapely.Geometry, target_crs: str, scale: int = 5000,
                       sheet_crs: str = "EPSG:4737") -> list[tuple[MapSheet, shapely.Polygon]]:
    """The sheets whose polygon (``sheet_polygon``) overlaps ``area`` (in ``target_crs``) with a positive
    area, with their polygons, in sheet-number order."""
    if area is None or area.is_empty or area.area <= 0:
        raise InputError("The area to tile is empty.")
    to_degrees = Transformer.from_crs(target_crs, sheet_crs, always_xy=True)
    ring = shapely.get_coordinates(shapely.segmentize(area.envelope, max(area.envelope.length / 256, 1.0)))
    lon, lat = to_degrees.transform(ring[:, 0], ring[:, 1])
    shapely.prepare(area)
    found = []
    for sheet in sheets_covering(min(lon), min(lat), max(lon), max(lat), scale):
        polygon = sheet_polygon(sheet, target_crs, sheet_crs)
        if area.intersects(polygon) and area.intersection(polygon).area > 0:
            found.append((sheet, polygon))
    return sorted(found, key=lambda pair: pair[0].number)
