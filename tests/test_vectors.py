"""wit:preparevectors core: reading (CP949, CRS), study areas, repairs, shared-wall simplification, output."""
from __future__ import annotations

import csv
import struct
from pathlib import Path

import numpy as np
import pytest
import shapely
from ngii import shapefile_text
from osgeo import ogr, osr

from wit_plugin.infra import polygons, step_layers
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.infra.io import vector_io
from wit_plugin.prepare import simplify, vectors
from wit_plugin.prepare.area import StudyArea
from wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors

SUSEO_5179 = (964814.9, 1943225.0)
SUSEO_5186 = (209020.9, 543132.8)


@pytest.fixture(scope="module")
def juso(shared_dir: Path) -> Path:
    return shared_dir / "data" / "juso_gangnam_11680_2019"


class Recorder(Feedback):
    def __init__(self, cancel_after: int | None = None):
        self.warnings: list[str] = []
        self.calls = 0
        self.cancel_after = cancel_after

    def warning(self, message: str) -> None:
        self.warnings.append(message)

    def is_canceled(self) -> bool:
        self.calls += 1
        return self.cancel_after is not None and self.calls > self.cancel_after


def write_shapefile(path: Path, polygons: list[str], rows: list[dict], epsg: int | None = 5186,
                    encoding: str = "CP949", geometry: int = ogr.wkbPolygon) -> Path:
    """A polygon (or ``geometry``) shapefile like the national data: DBF in ``encoding``, no .cpg."""
    ds = ogr.GetDriverByName("ESRI Shapefile").CreateDataSource(str(path))
    srs = None
    if epsg:
        srs = osr.SpatialReference()
        srs.ImportFromEPSG(epsg)
    with shapefile_text(encoding):  # in this encoding even after QGIS has set SHAPE_ENCODING=""
        lyr = ds.CreateLayer(path.stem, srs, geometry, options=[f"ENCODING={encoding}"])
        for name, value in rows[0].items():
            lyr.CreateField(ogr.FieldDefn(name, ogr.OFTInteger if isinstance(value, int) else ogr.OFTString))
        for wkt, row in zip(polygons, rows):
            feat = ogr.Feature(lyr.GetLayerDefn())
            for name, value in row.items():
                feat.SetField(name, value)
            feat.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
            lyr.CreateFeature(feat)
        ds = None
    path.with_suffix(".cpg").unlink(missing_ok=True)
    return path


def terrace(n: int = 5, width: float = 10.0, depth: float = 12.0, wall_vertices: int = 12,
            x0: float = 209000.0, y0: float = 543100.0) -> list[shapely.Polygon]:
    """A row of ``n`` buildings sharing walls; each wall has many nearly collinear vertices (±5 cm)."""
    rng = np.random.default_rng(7)
    walls = []
    for i in range(n + 1):
        t = np.linspace(0, depth, wall_vertices + 2)[1:-1]
        walls.append([(x0 + i * width + rng.normal(0, 0.05), y0 + v) for v in t])
    fronts = [[(x0 + i * width + u, y0 + rng.normal(0, 0.03)) for u in np.linspace(0, width, 6)[1:-1]]
              for i in range(n)]
    polys = []
    for i in range(n):
        ring = ([(x0 + i * width, y0)] + fronts[i] + [(x0 + (i + 1) * width, y0)] + walls[i + 1]
                + [(x0 + (i + 1) * width, y0 + depth), (x0 + i * width, y0 + depth)] + walls[i][::-1])
        polys.append(shapely.Polygon(ring))
    return polys


def assert_shared_walls(before: list[shapely.Geometry], after: np.ndarray) -> None:
    for i in range(len(before)):
        for j in range(i + 1, len(before)):
            inter_before = before[i].intersection(before[j])
            inter_after = after[i].intersection(after[j])
            assert inter_after.area < 1e-6, (i, j)
            if inter_before.length > 0:
                assert inter_after.geom_type in ("LineString", "MultiLineString"), (i, j, inter_after.geom_type)
                assert inter_after.length > 0.5 * inter_before.length


# -- reading ------------------------------------------------------------------------------------

def test_real_roads_read_in_cp949_with_their_crs(juso: Path):
    path = juso / "TL_SPRD_MANAGE.shp"
    assert vector_io.shapefile_encoding(path) == "CP949"
    layer = vector_io.read_layer(path)
    assert len(layer) == 1845
    assert layer.encoding == "CP949"
    assert "남부순환로" in layer.columns["RN"]
    assert "강남구 수서동 329-21" in layer.columns["REP_CN"]
    assert layer.crs.name == "PCS_ITRF2000_TM"
    suseo = polygons.transform(np.array([shapely.Point(*SUSEO_5179)]), layer.crs, vectors.pyproj.CRS("EPSG:5186"))
    x, y = suseo[0].coords[0]
    assert (x, y) == pytest.approx(SUSEO_5186, abs=0.1)


def test_field_mapping_reports_missing_fields(juso: Path):
    layer = vector_io.read_layer(juso / "TL_SPRD_MANAGE.shp")
    rec = Recorder()
    found = layer.field_map(vector_io.ROAD_FIELDS + ("NTFC_CD",), rec)
    assert found["NTFC_DE"] == "NTFC_DE" and "NTFC_CD" not in found
    assert len(rec.warnings) == 1 and "NTFC_CD" in rec.warnings[0] and "ROAD_BT" not in rec.warnings[0]


def test_explicit_encoding_wins_and_unknown_encoding_is_an_input_error(juso: Path):
    layer = vector_io.read_layer(juso / "TL_SCCO_EMD.shp", encoding="EUC-KR")
    assert "수서동" in layer.columns["EMD_KOR_NM"]
    with pytest.raises(InputError, match="Unknown text encoding"):
        vector_io.read_layer(juso / "TL_SCCO_EMD.shp", encoding="klingon")


def test_utf8_shapefile_without_cpg_is_sniffed(tmp_path: Path):
    path = write_shapefile(tmp_path / "b.shp", ["POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))"],
                           [{"BULD_NM": "수서역 빌딩"}], encoding="UTF-8")
    assert vector_io.shapefile_encoding(path) == "UTF-8"
    assert vector_io.read_layer(path).columns["BULD_NM"] == ["수서역 빌딩"]


def test_layer_without_crs_needs_a_source_crs(tmp_path: Path):
    path = write_shapefile(tmp_path / "nocrs.shp", ["POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))"],
                           [{"BUL_MAN_NO": 1}], epsg=None)
    with pytest.raises(InputError, match="no coordinate reference system"):
        vector_io.read_layer(path)
    assert vector_io.read_layer(path, crs="EPSG:5186").crs.to_epsg() == 5186
    area = StudyArea.circle(5, 5, 100, "EPSG:5186")
    with pytest.raises(InputError, match="give the source CRS"):
        prepare_vectors(path, None, None, area, tmp_path / "x.gpkg")
    report = prepare_vectors(path, None, None, area, tmp_path / "x.gpkg", PrepareConfig(source_crs="EPSG:5186"))
    assert report.stats[0].features_out == 1


# -- study areas --------------------------------------------------------------------------------

def test_one_km_around_suseo_gives_43_valid_roads_inside_the_circle(juso: Path, tmp_path: Path):
    out = tmp_path / "out.gpkg"
    area = StudyArea.circle(*SUSEO_5179, 1000, "EPSG:5179")
    report = prepare_vectors(None, juso / "TL_SPRD_MANAGE.shp", juso / "TL_SCCO_EMD.shp", area, out)
    roads = next(s for s in report.stats if s.layer == step_layers.PREPARED_ROADS)
    assert roads.features_out == 43
    centre = shapely.Point(SUSEO_5186)
    assert report.area.centroid.distance(centre) < 0.2
    assert report.area.area == pytest.approx(np.pi * 1000 ** 2, rel=1e-3)
    ds = ogr.Open(str(out))
    lyr = ds.GetLayerByName(step_layers.PREPARED_ROADS)
    geoms, widths, ids = [], [], []
    for f in lyr:
        geoms.append(shapely.from_wkb(bytes(f.GetGeometryRef().ExportToWkb())))
        widths.append((f[step_layers.ROAD_WIDTH], f[step_layers.ROAD_WIDTH_SOURCE], f["ROAD_BT"]))
        ids.append(f[step_layers.WIT_ID])
    geoms = np.array(geoms)
    assert len(geoms) == 43 and shapely.is_valid(geoms).all()
    assert shapely.contains(report.area.buffer(1e-6), geoms).all()
    assert shapely.distance(report.area.centroid, shapely.points(shapely.get_coordinates(geoms))).max() < 1000.01
    assert all(i.startswith("RD_11680_") for i in ids) and len(set(ids)) == 43
    assert all((w == bt and src == "ROAD_BT") or (bt == 0 and (src == "default" or src.startswith("ROA_CLS_SE=")))
               for w, src, bt in widths)
    # road polygons tile the road area: no overlaps between roads
    a, b = shapely.STRtree(geoms).query(geoms, predicate="intersects")
    assert max(shapely.area(shapely.intersection(geoms[a[a < b]], geoms[b[a < b]])), default=0) < 1e-3
    assert vectors.road_area(geoms).area == pytest.approx(shapely.area(geoms).sum(), rel=1e-6)
    districts = ds.GetLayerByName(step_layers.PREPARED_DISTRICTS)
    names = {f["EMD_KOR_NM"]: f[step_layers.WIT_ID] for f in districts}
    assert names["수서동"] == "EMD_11680115"


def test_district_code_selects_suseo_dong(juso: Path, tmp_path: Path):
    report = prepare_vectors(None, None, juso / "TL_SCCO_EMD.shp", StudyArea.from_district_code("11680115"),
                             tmp_path / "d.gpkg")
    assert report.area.contains(shapely.Point(SUSEO_5186))
    districts = next(s for s in report.stats if s.layer == step_layers.PREPARED_DISTRICTS)
    assert districts.features_out >= 1
    ds = ogr.Open(str(tmp_path / "d.gpkg"))
    kor = [f["EMD_KOR_NM"] for f in ds.GetLayerByName(step_layers.PREPARED_DISTRICTS)]
    assert "수서동" in kor


@pytest.mark.parametrize("name", ["역삼동", "Yeoksam-dong", "yeoksam-dong"])
def test_district_by_korean_or_english_name_is_the_code_area(juso: Path, tmp_path: Path, name: str):
    by_code = prepare_vectors(None, None, juso / "TL_SCCO_EMD.shp", StudyArea.from_district_code("11680101"),
                              tmp_path / "code.gpkg").area
    by_name = prepare_vectors(None, None, juso / "TL_SCCO_EMD.shp", StudyArea.from_district_code(name),
                              tmp_path / "name.gpkg").area
    assert by_name.equals_exact(by_code, 0) and by_code.area == pytest.approx(3.47e6, rel=0.02)  # 역삼동 3.47 km²


def test_district_layer_of_another_schema_names_its_fields(juso: Path, tmp_path: Path):
    """A dong layer from another source (code ADM_CD, name ADM_NM) selects by the fields it names."""
    other = vector_io.read_layer(juso / "TL_SCCO_EMD.shp", encoding="CP949")
    rows = [{"ADM_CD": code, "ADM_NM": name}
            for code, name in zip(other.columns["EMD_CD"], other.columns["EMD_KOR_NM"])]
    path = write_shapefile(tmp_path / "dongs.shp", [g.wkt for g in other.geoms], rows, epsg=5179, encoding="UTF-8")
    area = StudyArea.from_district_code("수서동", code_field="ADM_CD", name_field="ADM_NM")
    report = prepare_vectors(None, None, path, area, tmp_path / "o.gpkg")
    assert report.area.contains(shapely.Point(SUSEO_5186))
    with pytest.raises(InputError, match="has no field 'CODE'"):
        prepare_vectors(None, None, path, StudyArea.from_district_code("수서동", code_field="CODE"),
                        tmp_path / "p.gpkg")
    with pytest.raises(InputError, match="none of the fields EMD_CD, EMD_KOR_NM, EMD_ENG_NM"):
        prepare_vectors(None, None, path, StudyArea.from_district_code("수서동"), tmp_path / "q.gpkg")


def test_ambiguous_district_name_asks_for_the_code(tmp_path: Path):
    """신사동 exists in Gangnam-gu and in Eunpyeong-gu: a name matching two codes is refused."""
    squares = [shapely.box(0, 0, 100, 100).wkt, shapely.box(200, 0, 300, 100).wkt]
    path = write_shapefile(tmp_path / "emd.shp", squares, [{"EMD_CD": "11680107", "EMD_KOR_NM": "신사동"},
                                                             {"EMD_CD": "11380109", "EMD_KOR_NM": "신사동"}],
                           encoding="UTF-8")
    with pytest.raises(InputError, match="ambiguous.*11680107 신사동, 11380109 신사동"):
        prepare_vectors(None, None, path, StudyArea.from_district_code("신사동"), tmp_path / "o.gpkg",
                        vectors.PrepareConfig(source_crs="EPSG:5186"))


def test_study_area_from_a_polygon_wkt_in_another_crs(juso: Path, tmp_path: Path):
    x, y = SUSEO_5179
    area = StudyArea.polygon(shapely.box(x - 250, y - 250, x + 250, y + 250), "EPSG:5179")
    report = prepare_vectors(None, juso / "TL_SPRD_MANAGE.shp", None, area, tmp_path / "a.gpkg")
    assert report.area.area == pytest.approx(250000, rel=1e-3)  # a square is nearly a square in both TMs
    assert report.area.contains(shapely.Point(SUSEO_5186))


def test_study_area_from_a_polygon_layer(juso: Path, tmp_path: Path):
    x, y = SUSEO_5186
    square = shapely.box(x - 300, y - 300, x + 300, y + 300).wkt
    area_file = write_shapefile(tmp_path / "area.shp", [square], [{"id": 1}])
    report = prepare_vectors(None, juso / "TL_SPRD_MANAGE.shp", None, StudyArea.from_layer(area_file),
                             tmp_path / "a.gpkg")
    assert report.area.area == pytest.approx(360000, rel=1e-9)
    assert 0 < report.stats[0].features_out < 43


@pytest.mark.parametrize("kwargs, message", [
    (dict(roads="missing.shp"), "does not exist"),
    (dict(districts="EMD", area=StudyArea.from_district_code("99999999")),
     "neither a code nor a name in TL_SCCO_EMD.shp; it has 11680101 역삼동"),
    (dict(roads="ROADS", area=StudyArea.circle(126.0, 35.0, 500)), "does not overlap"),
    (dict(roads="ROADS", area=StudyArea.from_district_code("11680115")), "needs the district"),
])
def test_bad_inputs_raise_clear_input_errors(juso: Path, tmp_path: Path, kwargs: dict, message: str):
    paths = {"ROADS": juso / "TL_SPRD_MANAGE.shp", "EMD": juso / "TL_SCCO_EMD.shp"}
    args = dict(buildings=None, roads=None, districts=None, area=StudyArea.circle(*SUSEO_5179, 1000, "EPSG:5179"))
    args.update({k: paths.get(v, v) if isinstance(v, str) else v for k, v in kwargs.items()})
    with pytest.raises(InputError, match=message):
        prepare_vectors(output_gpkg=tmp_path / "x.gpkg", **args)
    assert not (tmp_path / "x.gpkg").exists()


def test_bad_parameters_raise_input_errors(juso: Path, tmp_path: Path):
    with pytest.raises(InputError, match="radius"):
        StudyArea.circle(127.1, 37.5, 0)
    with pytest.raises(InputError, match="projected in metres"):
        prepare_vectors(None, juso / "TL_SPRD_MANAGE.shp", None, StudyArea.circle(127.1, 37.5, 100),
                        tmp_path / "x.gpkg", PrepareConfig(target_crs="EPSG:4326"))


# -- repairs ------------------------------------------------------------------------------------

def _raw_polygon_shapefile(path: Path, rings: list[list[tuple[float, float]]]) -> None:
    """One polygon record per ring, written byte by byte so that rings may stay unclosed."""
    records = b""
    offsets = []
    for i, ring in enumerate(rings):
        pts = np.array(ring, dtype="<f8")
        content = struct.pack("<i4d2i", 5, *pts.min(0), *pts.max(0), 1, len(pts)) + struct.pack("<i", 0) + pts.tobytes()
        offsets.append((50 + len(records) // 2, len(content) // 2))
        records += struct.pack(">2i", i + 1, len(content) // 2) + content
    allpts = np.concatenate([np.array(r) for r in rings])
    bbox = struct.pack("<4d", *allpts.min(0), *allpts.max(0)) + struct.pack("<4d", 0, 0, 0, 0)

    def header(length_words: int) -> bytes:
        return struct.pack(">7i", 9994, 0, 0, 0, 0, 0, length_words) + struct.pack("<2i", 1000, 5) + bbox

    path.write_bytes(header(50 + len(records) // 2) + records)
    index = b"".join(struct.pack(">2i", *o) for o in offsets)
    path.with_suffix(".shx").write_bytes(header(50 + 4 * len(rings)) + index)
    field_descriptor = b"BUL_MAN_NO".ljust(11, b"\0") + b"N" + b"\0" * 4 + bytes([10, 0]) + b"\0" * 14
    dbf = struct.pack("<4BIHH20x", 3, 125, 1, 1, len(rings), 65, 11) + field_descriptor
    dbf += b"\r" + b"".join(b" " + str(i + 1).rjust(10).encode() for i in range(len(rings))) + b"\x1a"
    path.with_suffix(".dbf").write_bytes(dbf)
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    srs.MorphToESRI()
    path.with_suffix(".prj").write_text(srs.ExportToWkt())


def test_unclosed_rings_are_closed_and_counted(tmp_path: Path):
    path = tmp_path / "raw.shp"
    unclosed, closed = [(0, 0), (0, 10), (10, 10), (10, 0)], [(20, 0), (20, 10), (30, 10), (30, 0), (20, 0)]
    _raw_polygon_shapefile(path, [unclosed, closed])
    layer = vector_io.read_layer(path)
    assert list(layer.unclosed_rings) == [1, 0]
    assert shapely.is_valid(layer.geoms).all() and list(shapely.area(layer.geoms)) == [100, 100]
    repaired = polygons.repair_polygons(layer.geoms, layer.unclosed_rings)
    assert repaired.counts["unclosed_ring"] == 1


def test_each_defect_kind_is_repaired_and_counted():
    geoms = np.array([
        shapely.from_wkt("POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))"),  # clockwise? no: counter-clockwise, fine
        shapely.from_wkt("POLYGON ((20 0, 20 10, 30 10, 30 0, 20 0))"),  # clockwise shell
        shapely.from_wkt("POLYGON ((40 0, 50 0, 50 0.0004, 50 10, 40 10, 40 0))"),  # repeated vertex (0.4 mm)
        shapely.from_wkt("POLYGON ((60 0, 70 10, 70 0, 60 10, 60 0))"),  # bow-tie
        shapely.from_wkt("POLYGON ((80 0, 80.5 0, 80.5 1.5, 80 1.5, 80 0))"),  # 0.75 m²: too small
        shapely.from_wkt("POLYGON ((90 0, 130 0, 130 0.2, 90 0.2, 90 0))"),  # 8 m², 0.2 m wide: thin
        shapely.from_wkt("POLYGON ((0 20, 200 20, 200 23, 0 23, 0 20))"),  # long terrace 3 m wide: kept
        None,
        shapely.from_wkt("LINESTRING (0 0, 1 1)"),
        shapely.from_wkt("POLYGON ((0 40, 20 40, 20 60, 0 60, 0 40), (5 45, 15 45, 15 55, 5 55, 5 45))"),  # ccw hole
    ], dtype=object)
    rep = polygons.repair_polygons(geoms, np.zeros(len(geoms), int))
    assert rep.counts["orientation"] == 2  # the clockwise shell, the counter-clockwise hole
    assert rep.counts["repeated_vertex"] == 1
    assert rep.counts["invalid"] == 1 and rep.counts["multipart"] == 1
    assert list(rep.reasons) == [None, None, None, None, "too_small", "thin", None, "no_geometry", "wrong_type", None]
    out = rep.geoms[[0, 1, 2, 3, 6, 9]]
    assert shapely.is_valid(out).all()
    assert all(shapely.is_ccw(shapely.get_exterior_ring(p)) for g in out for p in shapely.get_parts(g))
    assert not shapely.is_ccw(rep.geoms[9].interiors[0]) and rep.geoms[9].area == 300
    assert shapely.get_num_coordinates(rep.geoms[2]) == 5
    bowtie = rep.geoms[3]
    assert bowtie.geom_type == "MultiPolygon" and len(bowtie.geoms) == 2 and bowtie.area == pytest.approx(50)


# -- shared walls -------------------------------------------------------------------------------

@pytest.mark.parametrize("tolerance", [0.5, 5.0])
def test_simplification_keeps_shared_walls_shared(tolerance: float):
    before = terrace()
    after, kept = simplify.simplify_shared(np.array(before, dtype=object), tolerance)
    assert shapely.is_valid(after).all()
    assert shapely.get_num_coordinates(after).sum() < shapely.get_num_coordinates(np.array(before)).sum() / 3
    assert_shared_walls(before, after)
    # the outline moves by less than the tolerance
    assert all(shapely.hausdorff_distance(b, a) <= tolerance + 1e-3 for b, a in zip(before, after))
    if tolerance < 1:  # 5 m may cut the corners of 10 m buildings (why buildings default to 0.5 m)
        assert shapely.union_all(after).area == pytest.approx(shapely.union_all(before).area, rel=0.01)


def test_simplification_never_lets_a_small_neighbour_get_swallowed():
    """A building in a notch: simplifying the big one's notch away would overlap it; the arc stays."""
    big = shapely.Polygon([(0, 0), (30, 0), (30, 10), (16, 10), (16, 10.6), (14, 10.6), (14, 10), (0, 10)])
    small = shapely.box(14.2, 10.05, 15.8, 10.5)
    after, kept = simplify.simplify_shared(np.array([big, small], dtype=object), 5.0)
    assert shapely.is_valid(after).all()
    assert after[0].intersection(after[1]).area < 1e-9
    assert kept >= 1


def test_simplification_on_real_districts_keeps_boundaries(juso: Path):
    layer = vector_io.read_layer(juso / "TL_SCCO_EMD.shp")
    geoms = polygons.repair_polygons(polygons.transform(layer.geoms, layer.crs, vectors.pyproj.CRS("EPSG:5186"))).geoms
    after, _ = simplify.simplify_shared(geoms, 5.0)
    assert shapely.is_valid(after).all()
    assert shapely.get_num_coordinates(after).sum() < 0.4 * shapely.get_num_coordinates(geoms).sum()
    a, b = shapely.STRtree(geoms).query(geoms, predicate="intersects")
    sel = a < b
    before_overlap = shapely.area(shapely.intersection(geoms[a[sel]], geoms[b[sel]]))
    after_overlap = shapely.area(shapely.intersection(after[a[sel]], after[b[sel]]))
    # no new overlaps (the source has a few slivers); snapping to the 1 mm grid moves edges by < 1 mm
    snapping = 1e-3 * np.minimum(shapely.length(geoms[a[sel]]), shapely.length(geoms[b[sel]]))
    assert np.all(after_overlap <= before_overlap + snapping)
    assert np.all(shapely.area(after) == pytest.approx(shapely.area(geoms), rel=0.01))


# -- end to end on synthetic buildings ----------------------------------------------------------

def test_buildings_end_to_end_attributes_korean_text_stats_and_csv(tmp_path: Path):
    row = terrace()
    x, y = 209000.0, 543100.0
    polys = [p.wkt for p in row] + [
        "POLYGON ((209070 543100, 209080 543100, 209070 543110, 209080 543110, 209070 543100))",  # bow-tie
        "POLYGON ((209100 543100, 209100.5 543100, 209100.5 543101, 209100 543101, 209100 543100))",  # too small
        "POLYGON ((209120 543100, 209160 543100, 209160 543100.2, 209120 543100.2, 209120 543100))",  # thin
        "POLYGON ((209480 543530, 209490 543530, 209490 543540, 209480 543540, 209480 543530))",  # outside
        "POLYGON ((219000 543100, 219010 543100, 219010 543110, 219000 543110, 219000 543100))",  # not even read
    ]
    rows = [{"BUL_MAN_NO": i + 1, "SIG_CD": "11680", "BULD_NM": f"수서 {i + 1}동", "GRO_FLO_CO": 3}
            for i in range(len(polys))]
    rows[0]["BUL_MAN_NO"] = 0  # a zero is a value, not a missing one
    path = write_shapefile(tmp_path / "TL_SPBD_BULD.shp", polys, rows)
    out = tmp_path / "prepared.gpkg"
    rec = Recorder()
    report = prepare_vectors(path, None, None, StudyArea.circle(x + 50, y, 500, "EPSG:5186"), out,
                             PrepareConfig(building_tolerance=0.5), rec)
    assert any("BD_MGT_SN" in w and "GRO_FLO_CO" not in w for w in rec.warnings)
    stats = report.stats[0]
    assert (stats.features_in, stats.features_out, stats.outside_area) == (9, 6, 1)
    assert stats.repaired["invalid"] == 1 and stats.repaired["multipart"] == 1
    assert stats.dropped == {"too_small": 1, "thin": 1}
    assert stats.vertices_out < stats.vertices_in / 2
    assert sorted((d.wit_id, d.reason) for d in report.dropped) == [("BLD_11680_7", "too_small"),
                                                                    ("BLD_11680_8", "thin")]
    ds = ogr.Open(str(out))
    lyr = ds.GetLayerByName(step_layers.PREPARED_BUILDINGS)
    feats = sorted(((f[step_layers.WIT_ID], f["BULD_NM"], f["GRO_FLO_CO"],
                     shapely.from_wkb(bytes(f.GetGeometryRef().ExportToWkb())))
                    for f in lyr), key=lambda t: t[0])
    assert [f[0] for f in feats] == ["BLD_11680_0", "BLD_11680_2", "BLD_11680_3", "BLD_11680_4", "BLD_11680_5",
                                     "BLD_11680_6"]
    assert [f[1] for f in feats] == [f"수서 {n}동" for n in range(1, 7)]
    assert all(f[2] == 3 for f in feats)
    geoms = {f[0]: f[3] for f in feats}
    assert all(g.is_valid for g in geoms.values())
    assert geoms["BLD_11680_6"].geom_type == "MultiPolygon"
    assert_shared_walls(row, np.array([geoms[k] for k in ["BLD_11680_0", "BLD_11680_2", "BLD_11680_3",
                                                          "BLD_11680_4", "BLD_11680_5"]], dtype=object))
    stats_rows = {f["layer"]: f for f in ds.GetLayerByName(vectors.STATS_TABLE)}
    assert stats_rows["buildings"]["dropped_thin"] == 1 and stats_rows["buildings"]["features_out"] == 6
    assert ds.GetLayerByName(vectors.DROPPED_TABLE).GetFeatureCount() == 2
    with open(report.stats_csv, encoding="utf-8") as fh:
        csv_rows = list(csv.DictReader(fh))
    assert csv_rows[0]["layer"] == "buildings" and csv_rows[0]["repaired_invalid"] == "1"


def test_cancel_leaves_no_output(juso: Path, tmp_path: Path):
    area = StudyArea.circle(*SUSEO_5179, 1000, "EPSG:5179")
    args = (None, juso / "TL_SPRD_MANAGE.shp", juso / "TL_SCCO_EMD.shp", area)
    counter = Recorder()
    prepare_vectors(*args, tmp_path / "full.gpkg", feedback=counter)
    for cancel_after in (1, counter.calls // 2, counter.calls - 1):  # early, midway, while writing
        with pytest.raises(CanceledError):
            prepare_vectors(*args, tmp_path / f"c{cancel_after}.gpkg", feedback=Recorder(cancel_after))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full.gpkg", "full_stats.csv"]


def test_generated_sample_prepares_cleanly(tmp_path: Path):
    sample = pytest.importorskip("wit_plugin.sample")
    config = sample.SampleConfig(radius_m=250.0, with_ortho=False, with_dem=False)
    result = sample.generate_sample(tmp_path / "s", config)
    report = prepare_vectors(result.buildings, result.roads, result.districts,
                             StudyArea.circle(sample.SampleConfig.center_lon, sample.SampleConfig.center_lat, 250.0,
                                              "EPSG:4737"),
                             tmp_path / "s.gpkg")
    buildings = next(s for s in report.stats if s.layer == step_layers.PREPARED_BUILDINGS)
    assert buildings.features_out > 20
    assert buildings.repaired["unclosed_ring"] + buildings.repaired["invalid"] > 0
    ds = ogr.Open(str(tmp_path / "s.gpkg"))
    geoms = np.array([shapely.from_wkb(bytes(f.GetGeometryRef().ExportToWkb()))
                      for f in ds.GetLayerByName(step_layers.PREPARED_BUILDINGS)])
    assert shapely.is_valid(geoms).all()
    a, b = shapely.STRtree(geoms).query(geoms, predicate="intersects")
    sel = a < b
    assert shapely.area(shapely.intersection(geoms[a[sel]], geoms[b[sel]])).max(initial=0) < 1e-3


def test_feature_loop_reader_matches_the_arrow_reader(juso: Path, monkeypatch: pytest.MonkeyPatch):
    """GDAL < 3.6 has no Arrow reader: the fallback must give the very same layer."""
    fast = vector_io.read_layer(juso / "TL_SPRD_MANAGE.shp")
    monkeypatch.delattr(ogr.Layer, "GetArrowStreamAsNumPy", raising=False)
    slow = vector_io.read_layer(juso / "TL_SPRD_MANAGE.shp")
    assert slow.columns == fast.columns
    assert list(slow.fids) == list(fast.fids)
    assert shapely.equals_exact(slow.geoms, fast.geoms, 0.0).all()


def test_sections_of_one_road_are_merged_into_one_polygon(tmp_path: Path):
    """Two sections with the same road id (SIG_CD, RDS_MAN_NO) are one road, not RD_x and RD_x_2."""
    path = write_shapefile(tmp_path / "TL_SPRD_MANAGE.shp",
                           ["LINESTRING (209000 543000, 209050 543000)", "LINESTRING (209050 543000, 209100 543000)",
                            "LINESTRING (209000 543050, 209100 543050)"],
                           [{"SIG_CD": "11680", "RDS_MAN_NO": "7"}] * 2 + [{"SIG_CD": "11680", "RDS_MAN_NO": "8"}],
                           geometry=ogr.wkbLineString)
    report = prepare_vectors(None, path, None, StudyArea.circle(209050, 543025, 500, "EPSG:5186"),
                             tmp_path / "out.gpkg", PrepareConfig(default_road_width=6.0))
    ds = ogr.Open(str(tmp_path / "out.gpkg"))
    roads = {f[step_layers.WIT_ID]: shapely.from_wkb(bytes(f.GetGeometryRef().ExportToWkb()))
             for f in ds.GetLayerByName(step_layers.PREPARED_ROADS)}
    assert sorted(roads) == ["RD_11680_7", "RD_11680_8"]
    assert roads["RD_11680_7"].bounds == pytest.approx((208997, 542997, 209103, 543003), abs=1e-3)
    assert report.stats[0].features_in == 3 and report.stats[0].features_out == 2


def test_duplicates_and_shared_ids_in_the_core():
    square = shapely.box(0, 0, 8, 8)
    turned = shapely.Polygon([(8, 0), (8, 8), (0, 8), (0, 0)])  # same footprint, other start and direction
    geoms = np.array([square, turned, square, shapely.box(20, 0, 28, 8), None], dtype=object)
    ids = ["BLD_1", "BLD_1", "BLD_2", "BLD_1", "BLD_3"]
    duplicate = polygons.exact_duplicates(geoms, ids)
    assert duplicate.tolist() == [False, True, False, False, False]
    assert vectors.unique_ids(ids, skip=duplicate) == ["BLD_1", "BLD_1", "BLD_2", "BLD_1_2", "BLD_3"]
    broken = shapely.Polygon([(0, 0), (np.inf, 0), (8, 8), (0, 0)])
    assert vector_io.non_finite(np.array([square, broken, None], dtype=object)).tolist() == [False, True, False]


@pytest.mark.parametrize("declaration", ["ldid_latin1", "ldid_cp1252", "cpg_latin1", "cpg_utf8"])
def test_cp949_text_under_a_wrong_declaration_is_read_as_cp949(declaration, juso: Path, tmp_path: Path):
    for part in juso.glob("TL_SCCO_EMD.*"):
        (tmp_path / part.name).write_bytes(part.read_bytes())
    dbf = tmp_path / "TL_SCCO_EMD.dbf"
    if declaration.startswith("ldid"):
        content = bytearray(dbf.read_bytes())
        content[29] = 0x57 if declaration == "ldid_latin1" else 0x03
        dbf.write_bytes(bytes(content))
    else:
        (tmp_path / "TL_SCCO_EMD.cpg").write_text("ISO-8859-1" if declaration == "cpg_latin1" else "UTF-8")
    rec = Recorder()
    layer = vector_io.read_layer(tmp_path / "TL_SCCO_EMD.shp", feedback=rec)
    assert layer.encoding == "CP949" and "역삼동" in layer.columns["EMD_KOR_NM"]
    assert len(rec.warnings) == 1 and "read as CP949" in rec.warnings[0], rec.warnings


def test_latin1_text_under_its_declaration_stays_latin1(tmp_path: Path):
    """French names decode as CP949 too (é + a letter is a CP949 pair), but are not Korean."""
    path = write_shapefile(tmp_path / "fr.shp", ["POLYGON ((0 0, 1 0, 1 1, 0 0))"] * 2,
                           [{"NOM": "Été à Paris"}, {"NOM": "Bâtiment élevé"}], encoding="ISO-8859-1")
    (tmp_path / "fr.cpg").write_text("ISO-8859-1")
    rec = Recorder()
    layer = vector_io.read_layer(path, feedback=rec)
    assert layer.columns["NOM"] == ["Été à Paris", "Bâtiment élevé"] and rec.warnings == []


def test_non_finite_coordinates_in_a_shapefile_are_read_dropped_and_counted(tmp_path: Path):
    """A shapefile whose polygons carry inf or NaN: the bounding-box filter used to drop the inf one
    unread (it vanished uncounted); both are now read, dropped as non_finite and listed."""
    polys = ["POLYGON ((209002 543002, 209010 543002, 209010 543010, 209002 543010, 209002 543002))",
             "POLYGON ((209022 543002, 123456 543002, 209030 543010, 209022 543010, 209022 543002))",
             "POLYGON ((209042 543002, 654321 543002, 209050 543010, 209042 543010, 209042 543002))"]
    path = write_shapefile(tmp_path / "TL_SPBD_BULD.shp", polys, [{"BD_MGT_SN": str(i)} for i in (1, 2, 3)])
    content = path.read_bytes()  # OGR refuses to write non-finite coordinates: patch them in
    content = content.replace(struct.pack("<d", 123456.0), struct.pack("<d", np.inf))
    path.write_bytes(content.replace(struct.pack("<d", 654321.0), struct.pack("<d", np.nan)))
    rec = Recorder()
    report = prepare_vectors(path, None, None, StudyArea.circle(209030, 543005, 200, "EPSG:5186"),
                             tmp_path / "out.gpkg", PrepareConfig(), rec)
    stats = report.stats[0]
    assert (stats.features_in, stats.features_out, stats.dropped) == (3, 1, {"non_finite": 2})
    assert sorted((d.wit_id, d.reason) for d in report.dropped) == [("BLD_2", "non_finite"), ("BLD_3", "non_finite")]
    assert any("dropped 2 feature(s): 2 non_finite" in w for w in rec.warnings), rec.warnings
