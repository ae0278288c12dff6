"""NGII sheet numbers: sheets with known footprints, every scale, bad names, and the real 1:5,000 index."""
from __future__ import annotations

import numpy as np
import pytest
from osgeo import ogr
from pyproj import Transformer

from wit_plugin.infra import mapsheet
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.mapsheet import MapSheet

CM = 0.01


@pytest.mark.parametrize("number, degrees, envelope", [
    ("37612093", (126.800, 37.250, 126.825, 37.275), (182256.11, 516772.30, 184479.23, 519551.27)),
    ("37709005", (127.100, 37.475, 127.125, 37.500), (208842.55, 541734.15, 211056.87, 544511.46)),
    ("37713074", (127.075, 37.050, 127.100, 37.075), (206669.31, 494564.49, 208895.34, 497341.01)),
])
def test_spec_worked_examples(number, degrees, envelope):
    sheet = mapsheet.parse_sheet_number(number)
    assert sheet.scale == 5000
    assert (sheet.west, sheet.south, sheet.east, sheet.north) == pytest.approx(degrees, abs=1e-12)
    assert mapsheet.projected_envelope(sheet) == pytest.approx(envelope, abs=CM)


def test_real_orthoimage_extent_with_50m_margin():
    # (B060)정사영상_2022_37713074.tif ↔ ULLR 206619.31 497391.01 208945.34 494514.49
    sheet = mapsheet.find_sheet_in_name("(B060)정사영상_2022_37713074.tif")
    xmin, ymin, xmax, ymax = mapsheet.projected_envelope(sheet, "EPSG:5186", "EPSG:4737", margin=50)
    assert (xmin, ymax, xmax, ymin) == pytest.approx((206619.31, 497391.01, 208945.34, 494514.49), abs=CM)


def test_bessel_datum_moves_the_sheet_by_hundreds_of_metres():
    sheet = mapsheet.parse_sheet_number("37709005")
    grs80 = mapsheet.projected_envelope(sheet)
    bessel = mapsheet.projected_envelope(sheet, source_crs="EPSG:4162")
    shift = np.hypot(bessel[0] - grs80[0], bessel[1] - grs80[1])
    assert 300 < shift < 450


@pytest.mark.parametrize("number, scale, west, south, size", [
    ("37709", 50000, 127.0, 37.25, 0.25),           # cell 09: row 2, column 0 of the 1° block
    ("377094", 25000, 127.125, 37.25, 0.125),       # south-east quarter
    ("3770901", 10000, 127.0, 37.45, 0.05),         # north-west fifth
    ("3770925", 10000, 127.2, 37.25, 0.05),         # south-east fifth
    ("37709005", 5000, 127.1, 37.475, 0.025),
    ("37709100", 5000, 127.225, 37.25, 0.025),      # south-east tenth
    ("377090100", 1000, 127.0, 37.495, 0.005),      # 00: north-west cell of 1:10k sheet 3770901
    ("377090109", 1000, 127.045, 37.495, 0.005),    # 09: north-east
    ("377090110", 1000, 127.0, 37.49, 0.005),       # 10: second row, west
    ("377090199", 1000, 127.045, 37.45, 0.005),     # 99: south-east
    ("37016", 50000, 130.75, 37.0, 0.25),           # digit 0 = 130°E (Ulleungdo)
    ("371", None, None, None, None),
])
def test_every_scale_parses_nests_and_round_trips(number, scale, west, south, size):
    if scale is None:
        with pytest.raises(InputError):
            mapsheet.parse_sheet_number(number)
        return
    sheet = mapsheet.parse_sheet_number(number)
    assert sheet == MapSheet(number, scale, pytest.approx(west, abs=1e-12), pytest.approx(south, abs=1e-12),
                             pytest.approx(west + size, abs=1e-12), pytest.approx(south + size, abs=1e-12))
    centre = ((sheet.west + sheet.east) / 2, (sheet.south + sheet.north) / 2)
    assert mapsheet.sheet_at(*centre, scale=scale) == sheet
    # a point on the south-west corner belongs to this sheet (edges go to the cell east/north)
    assert mapsheet.sheet_at(sheet.west, sheet.south, scale) == sheet
    parent = mapsheet.sheet_at(*centre, scale=50000)
    assert number.startswith(parent.number)
    px = mapsheet.projected_envelope(parent)
    sx = mapsheet.projected_envelope(sheet)
    assert px[0] <= sx[0] < sx[2] <= px[2] and px[1] <= sx[1] < sx[3] <= px[3]


def test_all_scales_share_the_grid():
    lon, lat = 127.1031, 37.4872  # Suseo station
    sheets = {scale: mapsheet.sheet_at(lon, lat, scale) for scale in mapsheet.SCALES}
    assert {s: sh.number for s, sh in sheets.items()} == {
        50000: "37709", 25000: "377091", 10000: "3770903", 5000: "37709005", 1000: "377090320"}
    # 1:10,000 cells (0.05°) do not nest in 1:25,000 cells (0.125°); every other pair does
    for small, large in [(50000, 25000), (50000, 10000), (10000, 5000), (10000, 1000), (5000, 1000)]:
        a, b = sheets[small], sheets[large]
        assert a.west <= b.west < b.east <= a.east and a.south <= b.south < b.north <= a.north
    assert sheets[1000].number.startswith(sheets[10000].number)
    assert sheets[5000].number.startswith(sheets[50000].number)


def test_sheets_covering_reading_order_and_exact_edges():
    sheets = mapsheet.sheets_covering(127.1, 37.475, 127.15, 37.5)  # exactly two sheets wide
    assert [s.number for s in sheets] == ["37709005", "37709006"]
    sheets = mapsheet.sheets_covering(127.11, 37.47, 127.13, 37.49)
    assert [s.number for s in sheets] == ["37709005", "37709006", "37709015", "37709016"]
    assert [s.number for s in mapsheet.sheets_covering(127.0, 37.0, 127.25, 37.25, 25000)] == [
        "377131", "377132", "377133", "377134"]
    assert len(mapsheet.sheets_covering(127.0, 37.25, 127.25, 37.5, 5000)) == 100
    assert [s.number for s in mapsheet.sheets_covering(127.11, 37.48, 127.11, 37.48)] == ["37709005"]
    with pytest.raises(InputError, match="invalid box"):
        mapsheet.sheets_covering(127.2, 37.0, 127.1, 37.1)


@pytest.mark.parametrize("digits, reason", [
    ("", "digits 0–9 only"),
    ("3770", "4 digits"),
    ("377090052", "cell 00 out of range 01–25 at 1:10,000"),  # 9 digits: 1:10k parent 3770900
    ("1234567890", "10 digits"),
    ("37700", "cell 00 out of range 01–16 at 1:50,000"),
    ("37717", "cell 17 out of range 01–16 at 1:50,000"),
    ("377095", "cell 5 out of range 1–4 at 1:25,000"),
    ("3770926", "cell 26 out of range 01–25 at 1:10,000"),
    ("37709000", "cell 000 out of range 001–100 at 1:5,000"),
    ("37709101", "cell 101 out of range 001–100 at 1:5,000"),
    ("3770900a", "digits 0–9 only"),
    ("３７７０９００５", "digits 0–9 only"),  # full-width digits
    ("31709005", "latitude block 31°N is outside Korea"),
    ("44709005", "latitude block 44°N is outside Korea"),
    ("37209005", "longitude digit 2"),
    ("37309005", "longitude digit 3"),
])
def test_invalid_numbers_say_why(digits, reason):
    with pytest.raises(InputError) as err:
        mapsheet.parse_sheet_number(digits)
    assert reason in str(err.value)


@pytest.mark.parametrize("name, number", [
    ("(B060)정사영상_2022_37713074.tif", "37713074"),
    ("37612093.tif", "37612093"),
    ("/data/2022/정사영상/37709005.TIF", "37709005"),
    ("20220315_37713074_v2.tif", "37713074"),       # a date is 8 digits but not a sheet
    ("37709005-37709005.tif", "37709005"),          # the same number twice is not ambiguous
    ("1:1000_377090852.tif", "377090852"),
])
def test_find_sheet_in_name(name, number):
    assert mapsheet.find_sheet_in_name(name).number == number


@pytest.mark.parametrize("name, reason", [
    ("", "no 5–9 digit sheet number"),
    ("정사영상_2022.tif", "no 5–9 digit sheet number"),
    ("3771.tif", "no 5–9 digit sheet number"),
    ("377130740123.tif", "no 5–9 digit sheet number"),
    ("ortho_37709101.tif", "cell 101 out of range 001–100 at 1:5,000"),
    ("map_37717.tif", "cell 17 out of range 01–16 at 1:50,000"),
    ("37709005_37713074.tif", "ambiguous"),
])
def test_find_sheet_in_name_rejects(name, reason):
    with pytest.raises(InputError, match=reason):
        mapsheet.find_sheet_in_name(name)


def test_point_outside_korea_and_bad_scale():
    with pytest.raises(InputError, match="outside the NGII sheet grid"):
        mapsheet.sheet_at(139.7, 35.7)  # Tokyo
    with pytest.raises(InputError, match="not an NGII sheet scale"):
        mapsheet.sheet_at(127.1, 37.5, 2500)
    with pytest.raises(InputError, match="cannot transform"):
        mapsheet.projected_envelope(mapsheet.parse_sheet_number("37709005"), "EPSG:999999")


def test_real_ngii_5k_index(shared_dir):
    """Each polygon of the NGII index is its sheet's projected envelope + 50 m, except in the far south.

    The index is rounded to whole metres (and computed with a few mm of difference from PROJ), so
    "within 0.5 m" means ≤ 0.5 m + 6 mm: 369 sheets sit 0.503–0.505 m off on one side.
    """
    path = shared_dir / "data" / "ngii_mapindex_5k_buffered_5186" / "MAPINDX_5K_BUF_J_5186.shp"
    ds = ogr.Open(str(path))
    boxes = np.array([f.GetGeometryRef().GetEnvelope() for f in ds.GetLayer(0)])  # minx, maxx, miny, maxy
    assert len(boxes) == 18083
    index = boxes[:, [0, 2, 1, 3]]  # xmin, ymin, xmax, ymax
    to_geo = Transformer.from_crs("EPSG:5186", "EPSG:4737", always_xy=True)
    lons, lats = to_geo.transform((index[:, 0] + index[:, 2]) / 2, (index[:, 1] + index[:, 3]) / 2)
    sheets = [mapsheet.sheet_at(lon, lat, 5000) for lon, lat in zip(lons, lats)]
    assert len({s.number for s in sheets}) == 18083
    ours = np.array([mapsheet.projected_envelope(s, margin=50) for s in sheets])
    error = np.abs(ours - index).max(axis=1)
    match = error <= 0.506
    assert match.sum() == 17885
    assert (error[match] <= 0.5).sum() == 17885 - 369

    off = ~match
    assert off.sum() == 198
    assert all(s.north <= 33.4 for s, o in zip(sheets, off) if o)
    dx = ours[:, [0, 2]] - index[:, [0, 2]]  # the index lies west of the rule: ours − index > 0
    dy = ours[:, [1, 3]] - index[:, [1, 3]]
    west = off & (dx > 765).all(axis=1) & (dx < 780).all(axis=1) & (np.abs(dy) < 7).all(axis=1)
    assert west.sum() == 197
    # the 198th is Ieodo ocean station's sheet: a non-standard 2552 m × 2990 m box at 32.1°N
    (odd,) = np.flatnonzero(off & ~west)
    assert sheets[odd].number == "32513058"
    assert index[odd, 2] - index[odd, 0] == pytest.approx(2552, abs=0.01)
    assert index[odd, 3] - index[odd, 1] == pytest.approx(2990, abs=0.01)
