"""The sample-data generator: real schemas, CP949, CRSs, recorded defects, geometry and tiles."""
from __future__ import annotations

import filecmp
import json
import struct
from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import gdal, ogr, osr
from pyproj import Transformer

from wit_plugin import sample
from wit_plugin.infra import mapsheet
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback

SMALL = sample.SampleConfig(radius_m=300.0, ortho_pixel_size=2.0)
SUSEO_5179 = Transformer.from_crs("EPSG:4737", "EPSG:5179", always_xy=True).transform(127.1020, 37.4876)

BUILDING_SCHEMA = [
    ("BDTYP_CD", "String", 5), ("BD_MGT_SN", "String", 25), ("BSI_INT_SN", "Integer64", 10),
    ("BSI_ZON_NO", "String", 5), ("BULD_MNNM", "Integer", 5), ("BULD_NM", "String", 100),
    ("BULD_NM_DC", "String", 100), ("BULD_SE_CD", "String", 1), ("BULD_SLNO", "Integer", 5),
    ("BUL_DPN_SE", "String", 1), ("BUL_ENG_NM", "String", 100), ("BUL_MAN_NO", "Integer64", 10),
    ("EMD_CD", "String", 3), ("EQB_MAN_SN", "Integer64", 10), ("GRO_FLO_CO", "Integer", 3), ("LI_CD", "String", 2),
    ("LNBR_MNNM", "Integer", 4), ("LNBR_SLNO", "Integer", 4), ("MNTN_YN", "String", 1), ("NTFC_DE", "String", 8),
    ("OPERT_DE", "String", 14), ("POS_BUL_NM", "String", 40), ("RDS_MAN_NO", "Integer64", 12),
    ("RDS_SIG_CD", "String", 5), ("RN_CD", "String", 7), ("SIG_CD", "String", 5), ("UND_FLO_CO", "Integer", 3),
]


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> sample.SampleResult:
    return sample.generate_sample(tmp_path_factory.mktemp("sample"), SMALL)


def _open(path: Path, cp949: bool = True) -> gdal.Dataset:
    return gdal.OpenEx(str(path), gdal.OF_VECTOR, open_options=["ENCODING=CP949"] if cp949 else [])


def _schema(path: Path) -> list[tuple]:
    ds = _open(path)  # keep the dataset alive while its layer is used
    defn = ds.GetLayer(0).GetLayerDefn()
    return [(defn.GetFieldDefn(k).GetName(), defn.GetFieldDefn(k).GetTypeName(), defn.GetFieldDefn(k).GetWidth(),
             defn.GetFieldDefn(k).GetPrecision()) for k in range(defn.GetFieldCount())]


def _features(path: Path) -> list[tuple[dict, object]]:
    """(attributes, shapely geometry as OGR reads it; unclosed rings closed) per feature."""
    ds = _open(path)
    return [(f.items(), shapely.from_wkb(bytes(f.GetGeometryRef().ExportToWkb()), on_invalid="fix"))
            for f in ds.GetLayer(0)]


def _values(path: Path, name: str, cp949: bool = True) -> list:
    ds = _open(path, cp949)
    return [f.GetField(name) for f in ds.GetLayer(0)]


def _layer_info(path: Path) -> tuple[int, osr.SpatialReference]:
    ds = _open(path)
    layer = ds.GetLayer(0)
    return layer.GetGeomType(), layer.GetSpatialRef().Clone()


def _raw_parts(path: Path) -> list[list[np.ndarray]]:
    """The rings/parts of every record exactly as stored in the .shp (OGR would repair them)."""
    data, pos, out = path.read_bytes(), 100, []
    while pos < len(data):
        _, words = struct.unpack(">2i", data[pos:pos + 8])
        content = data[pos + 8:pos + 8 + 2 * words]
        n_parts, n_points = struct.unpack("<2i", content[36:44])
        starts = list(np.frombuffer(content[44:44 + 4 * n_parts], "<i4")) + [n_points]
        points = np.frombuffer(content[44 + 4 * n_parts:], "<f8").reshape(-1, 2)
        out.append([points[starts[k]:starts[k + 1]] for k in range(n_parts)])
        pos += 8 + 2 * words
    return out


def _signed_area(ring: np.ndarray) -> float:
    """Shoelace area, positive for counter-clockwise rings (computed about the first vertex)."""
    x, y = (ring - ring[0]).T
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


# --- schema, encoding, CRS --------------------------------------------------------------------------

def test_building_schema_is_the_road_name_address_schema(small):
    assert [s[:3] for s in _schema(small.buildings)] == BUILDING_SCHEMA
    assert _layer_info(small.buildings)[0] == ogr.wkbPolygon


@pytest.mark.parametrize("layer", ["TL_SPRD_MANAGE", "TL_SCCO_EMD"])
def test_road_and_district_schemas_equal_the_real_gangnam_files(small, shared_dir, layer):
    real = shared_dir / "data" / "juso_gangnam_11680_2019" / f"{layer}.shp"
    assert _schema(small.folder / f"{layer}.shp") == _schema(real)
    assert _layer_info(small.folder / f"{layer}.shp")[0] == _layer_info(real)[0]


def test_files_are_cp949_without_cpg_like_juso_downloads(small):
    for name in ("TL_SPBD_BULD", "TL_SPRD_MANAGE", "TL_SCCO_EMD"):
        assert not (small.folder / f"{name}.cpg").exists()
        assert (small.folder / f"{name}.dbf").read_bytes()[29] == 0
    assert "수서동" in _values(small.districts, "EMD_KOR_NM")
    raw = _values(small.districts, "EMD_KOR_NM", cp949=False)
    assert "수서동" not in raw  # mojibake without the encoding option
    assert "수서동".encode("cp949") in small.districts.with_suffix(".dbf").read_bytes()
    roads = _values(small.roads, "RN")
    assert all(r.endswith(("로", "길")) for r in roads)


def test_vectors_are_epsg_5179_and_dem_epsg_5186(small):
    for path in (small.buildings, small.roads, small.districts):
        srs = _layer_info(path)[1]
        matches = srs.FindMatches()
        assert matches and matches[0][0].GetAuthorityCode(None) == "5179" and matches[0][1] >= 90
    dem = gdal.Open(str(small.dem))
    srs = osr.SpatialReference(wkt=dem.GetProjection())
    assert srs.GetAuthorityCode(None) == "5186"


# --- content ------------------------------------------------------------------------------------------

def test_counts_codes_and_numbers_are_plausible(small):
    rows = [a for a, _ in _features(small.buildings)]
    assert 150 <= len(rows) <= 1000
    assert small.counts["buildings"] == len(rows)
    ids = [r["BUL_MAN_NO"] for r in rows]
    assert len(set(ids)) == len(ids)
    mgt = [r["BD_MGT_SN"] for r in rows]
    assert len(set(mgt)) == len(mgt) and all(len(m) == 25 and m.isdigit() for m in mgt)
    for r in rows:
        assert r["BD_MGT_SN"] == (f"{r['SIG_CD']}{r['EMD_CD']}{r['LI_CD']}{r['MNTN_YN']}"
                                  f"{r['LNBR_MNNM']:04d}{r['LNBR_SLNO']:04d}") + r["BD_MGT_SN"][19:]
    assert {r["SIG_CD"] for r in rows} == {"11680"}
    assert {r["BDTYP_CD"][:2] for r in rows} >= {"01", "02", "03"}
    apartments = [r for r in rows if r["BDTYP_CD"] == "02001" and r["BULD_NM_DC"].endswith("동")
                  and r["BULD_NM_DC"][:-1].isdigit()]
    if apartments:
        assert all(r["BULD_NM"].endswith("아파트") and 12 <= r["GRO_FLO_CO"] <= 25 for r in apartments)
    houses = [r["GRO_FLO_CO"] for r in rows if r["BDTYP_CD"] == "01001" and r["GRO_FLO_CO"]]
    assert houses and max(houses) <= 3
    roads = {r["RDS_MAN_NO"]: r for r, _ in _features(small.roads)}
    assert all(r["RN_CD"] == roads[r["RDS_MAN_NO"]]["RN_CD"] for r in rows)


def test_default_area_has_gangnam_density():
    config = sample.SampleConfig(with_ortho=False, with_dem=False)
    from wit_plugin.sample.layout import CityLayout
    from wit_plugin.sample.rasters import Terrain
    from wit_plugin.sample.vectors import select
    layout = CityLayout(tuple(np.array(SUSEO_5179)), config.seed, Terrain(config.seed))
    data = select(layout, config.radius_m, None, 1e-3)
    centres = np.array([b.rings[0][:-1].mean(axis=0) for b in data.buildings])
    within = int((np.hypot(*(centres - np.array(SUSEO_5179)).T) <= 1000.0).sum())
    assert 3000 <= within <= 5000


def test_n_buildings_sets_the_size(tmp_path):
    result = sample.generate_sample(tmp_path, sample.SampleConfig(n_buildings=400, with_ortho=False,
                                                                  with_dem=False))
    assert 400 <= result.counts["buildings"] <= 400 + 3 * 2  # plus the sliver features
    assert result.radius_m < 400


def test_defects_are_exactly_the_recorded_ones(small):
    parts = _raw_parts(small.buildings)
    ids = [a["BUL_MAN_NO"] for a, _ in _features(small.buildings)]
    floors = [a["GRO_FLO_CO"] for a, _ in _features(small.buildings)]
    found: dict[str, set[int]] = {kind: set() for kind in small.defects}
    for k, rings in enumerate(parts):
        exterior = rings[0]
        closed = np.array_equal(exterior[0], exterior[-1])
        if not closed:
            found["unclosed_ring"].add(ids[k])
            continue
        if np.any(np.all(exterior[1:] == exterior[:-1], axis=1)):
            found["duplicate_vertex"].add(ids[k])
        polygon = shapely.Polygon(exterior, rings[1:])
        if not shapely.is_valid(polygon) and "Self-intersection" in shapely.is_valid_reason(polygon):
            found["self_intersection"].add(ids[k])  # a bow-tie has no winding
            continue
        if _signed_area(exterior) > 0:
            found["wrong_winding"].add(ids[k])
        if polygon.area < 1.0:
            assert polygon.area / polygon.length < 0.05  # thin, not merely small
            found["sliver"].add(ids[k])
        for hole in rings[1:]:
            assert _signed_area(hole) > 0  # holes counter-clockwise
        if floors[k] in (None, 0):
            found["missing_floors"].add(ids[k])
    assert set(small.defects) == set(found)
    for kind, recorded in small.defects.items():
        assert len(recorded) >= 1 and set(recorded) == found[kind], kind
    manifest = json.loads(small.manifest.read_text(encoding="utf-8"))
    assert manifest["defects"] == small.defects


def _clean_buildings(small) -> tuple[list[dict], np.ndarray]:
    bad = {i for ids in small.defects.values() for i in ids}
    rows = [(a, g) for a, g in _features(small.buildings) if a["BUL_MAN_NO"] not in bad]
    return [a for a, _ in rows], np.array([g for _, g in rows], dtype=object)


def test_buildings_share_walls_without_overlaps(small):
    _, geoms = _clean_buildings(small)
    assert shapely.is_valid(geoms).all()
    tree = shapely.STRtree(geoms)
    left, right = tree.query(geoms, predicate="intersects")
    pairs = [(a, b) for a, b in zip(left, right) if a < b]
    overlap = shapely.area(shapely.intersection(geoms[[a for a, _ in pairs]], geoms[[b for _, b in pairs]]))
    assert overlap.max() < 1e-6
    shared = shapely.length(shapely.intersection(shapely.boundary(geoms[[a for a, _ in pairs]]),
                                                 shapely.boundary(geoms[[b for _, b in pairs]])))
    assert (shared > 2.0).sum() >= 10
    a, b = pairs[int(np.argmax(shared))]
    common = ({tuple(p) for p in shapely.get_coordinates(geoms[a])}
              & {tuple(p) for p in shapely.get_coordinates(geoms[b])})
    assert len(common) >= 2  # the shared wall's ends are the very same vertices


def test_roads_do_not_run_through_buildings(small):
    _, geoms = _clean_buildings(small)
    roads = [(shapely.buffer(g, a["ROAD_BT"] / 2)) for a, g in _features(small.roads)]
    assert len(roads) >= 5
    hit = shapely.intersection(shapely.union_all(roads), shapely.union_all(geoms))
    assert hit.area < 1e-6


def test_every_building_lies_in_the_district_of_its_emd_code(small, shared_dir):
    real = {a["EMD_CD"]: a["EMD_KOR_NM"]
            for a, _ in _features(shared_dir / "data" / "juso_gangnam_11680_2019" / "TL_SCCO_EMD.shp")}
    districts = _features(small.districts)
    assert all(real[a["EMD_CD"]] == a["EMD_KOR_NM"] for a, _ in districts)
    station = shapely.Point(SUSEO_5179)
    assert [a["EMD_KOR_NM"] for a, g in districts if g.contains(station)] == ["수서동"]
    by_code = {a["EMD_CD"][5:]: g for a, g in districts}
    for attrs, geom in _features(small.buildings):
        assert by_code[attrs["EMD_CD"]].contains(shapely.point_on_surface(geom))


def test_big_sample_has_several_districts(tmp_path):
    result = sample.generate_sample(tmp_path, sample.SampleConfig(with_ortho=False, with_dem=False))
    names = set(_values(result.districts, "EMD_KOR_NM"))
    assert {"수서동", "일원동", "자곡동"} <= names and len(names) >= 4


def test_dem_has_undeclared_minus_9999_holes_and_real_relief(small):
    ds = gdal.Open(str(small.dem))
    band = ds.GetRasterBand(1)
    assert band.GetNoDataValue() is None and band.DataType == gdal.GDT_Float32
    values = band.ReadAsArray()
    holes = values == -9999.0
    assert 3 <= holes.sum() <= max(3, 0.002 * values.size)
    valid = values[~holes]
    assert 2.0 <= valid.min() and valid.max() < 400.0
    gt = ds.GetGeoTransform()
    assert gt[1] == SMALL.dem_cell_size
    x, y = Transformer.from_crs("EPSG:4737", "EPSG:5186", always_xy=True).transform(127.1020, 37.4876)
    station = values[int((y - gt[3]) / gt[5]), int((x - gt[0]) / gt[1])]
    assert 5.0 <= station <= 40.0
    assert np.nanmax(np.abs(np.diff(np.where(holes, np.nan, values), axis=1))) < 5.0  # smooth, no steps


def test_default_dem_has_the_hills_south_west_of_suseo():
    from wit_plugin.sample.rasters import Terrain
    terrain = Terrain(42)
    x0, y0 = Transformer.from_crs("EPSG:4737", "EPSG:5186", always_xy=True).transform(127.1020, 37.4876)
    daemosan = terrain(np.array([x0 - 1794.0]), np.array([y0 - 1378.0]))[0]
    assert 230.0 <= daemosan <= 330.0 and terrain(np.array([x0]), np.array([y0]))[0] < 40.0


# --- orthoimage tiles -----------------------------------------------------------------------------------

def test_tiles_are_unreferenced_ngii_named_sheets(small):
    assert small.counts["tiles"] == len(small.ortho_tiles) >= 2
    numbers = []
    for path in small.ortho_tiles:
        sheet = mapsheet.find_sheet_in_name(path.name)
        numbers.append(sheet.number)
        assert path.name == f"(B060)정사영상_2022_{sheet.number}.tif"
        ds = gdal.Open(str(path))
        assert ds.GetGeoTransform(can_return_null=True) is None and ds.GetProjection() == ""
        assert ds.RasterCount == 3 and ds.GetRasterBand(1).DataType == gdal.GDT_Byte
        xmin, ymin, xmax, ymax = mapsheet.projected_envelope(sheet, "EPSG:5186", margin=50.0)
        assert (ds.RasterXSize, ds.RasterYSize) == (round((xmax - xmin) / 2.0), round((ymax - ymin) / 2.0))
        for suffix in (".tfw", ".tif.aux.xml", ".aux.xml"):
            assert not path.with_name(path.stem + suffix).exists() and not Path(str(path) + ".aux.xml").exists()
    assert mapsheet.sheet_at(127.1020, 37.4876).number in numbers
    to_4737 = Transformer.from_crs("EPSG:5179", "EPSG:4737", always_xy=True)
    for dx in (-300.0, 300.0):  # every corner of the study square lies on one of the sheets
        for dy in (-300.0, 300.0):
            lon, lat = to_4737.transform(SUSEO_5179[0] + dx, SUSEO_5179[1] + dy)
            assert mapsheet.sheet_at(lon, lat).number in numbers


def _tile_pixels(small) -> list[tuple[tuple, np.ndarray]]:
    out = []
    for path in small.ortho_tiles:
        sheet = mapsheet.find_sheet_in_name(path.name)
        out.append((mapsheet.projected_envelope(sheet, "EPSG:5186", margin=50.0),
                    gdal.Open(str(path)).ReadAsArray().astype(float)))
    return out


def test_roofs_are_drawn_where_the_buildings_are(small):
    rows, geoms = _clean_buildings(small)
    to_5186 = Transformer.from_crs("EPSG:5179", "EPSG:5186", always_xy=True)
    tiles = _tile_pixels(small)
    picked = [g for a, g in zip(rows, geoms) if a["BDTYP_CD"] == "02001" and g.area > 150]
    picked = picked or [g for a, g in zip(rows, geoms) if a["BDTYP_CD"] == "14201" and g.area > 150]
    assert picked
    checked = 0
    for geom in picked[:20]:
        inner = shapely.buffer(geom, -3.0)
        if inner.is_empty:
            continue
        x, y = to_5186.transform(*shapely.get_coordinates(shapely.point_on_surface(inner))[0])
        for (xmin, ymin, xmax, ymax), px in tiles:
            if xmin < x < xmax and ymin < y < ymax:
                rgb = px[:, int((ymax - y) / 2.0), int((x - xmin) / 2.0)]
                assert rgb.mean() > 110 and rgb.max() - rgb.min() < 45, rgb  # grey/white concrete
                checked += 1
                break
    assert checked >= 3


def test_tiles_differ_in_brightness_in_their_overlap(small):
    (env_a, a), (env_b, b) = sorted(_tile_pixels(small), key=lambda t: t[0][0])[:2]
    x0, x1 = env_b[0], env_a[2]  # the overlap strip along the sheet edge
    y0, y1 = max(env_a[1], env_b[1]) + 50, min(env_a[3], env_b[3]) - 50
    assert x1 - x0 > 80
    xs, ys = np.arange(x0 + 10, x1 - 10, 4.0), np.arange(y0, y1, 4.0)

    def sample_at(env, img):
        cols = ((xs - env[0]) / 2.0).astype(int)
        rows = ((env[3] - ys) / 2.0).astype(int)
        return img[:, rows[:, None], cols[None, :]].mean(axis=0)

    sa, sb = sample_at(env_a, a), sample_at(env_b, b)
    assert abs(sa.mean() / sb.mean() - 1.0) > 0.04
    assert np.corrcoef(sa.ravel(), sb.ravel())[0, 1] > 0.6  # same ground, different exposure


# --- behaviour ------------------------------------------------------------------------------------------

def test_same_seed_same_bytes_other_seed_other_data(small, tmp_path):
    again = sample.generate_sample(tmp_path / "again", SMALL)
    names = sorted(str(p.relative_to(small.folder)) for p in small.folder.rglob("*") if p.is_file())
    assert names == sorted(str(p.relative_to(again.folder)) for p in again.folder.rglob("*") if p.is_file())
    assert any(n.startswith("ortho/") for n in names)
    match, mismatch, errors = filecmp.cmpfiles(small.folder, again.folder, names, shallow=False)
    assert not mismatch and not errors
    other = sample.generate_sample(tmp_path / "other", sample.SampleConfig(radius_m=300.0, seed=7, with_ortho=False))
    assert other.buildings.read_bytes() != small.buildings.read_bytes()


@pytest.mark.parametrize("config", [sample.SampleConfig(center_lon=2.35, center_lat=48.85),
                                    sample.SampleConfig(radius_m=0.0), sample.SampleConfig(ortho_pixel_size=0.0),
                                    sample.SampleConfig(n_buildings=0)])
def test_bad_configuration_is_refused(tmp_path, config):
    with pytest.raises(InputError):
        sample.generate_sample(tmp_path, config)


def test_cancel_leaves_nothing_behind(tmp_path):
    class CancelLater(Feedback):
        def __init__(self):
            self.seen = 0.0

        def progress(self, percent):
            self.seen = percent

        def is_canceled(self):
            return self.seen > 25.0

    with pytest.raises(CanceledError):
        sample.generate_sample(tmp_path / "out", SMALL, CancelLater())
    assert not (tmp_path / "out").exists()  # the folder made for the run is removed too
