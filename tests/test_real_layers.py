"""Real national layers in the form they ship, core only: Korean field names in CP949 read
without a crash under QGIS's GDAL settings, NGII / OpenStreetMap road schemas, road polygons as road
surfaces, step inputs of any layer name. Layers are made by the tests (``ngii``)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import ngii
import numpy as np
import pytest
import shapely
from conftest import ROOT
from osgeo import gdal, ogr

from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.infra.io import bulk_read, vector_io
from wit_plugin.prepare import roads
from wit_plugin.prepare.area import StudyArea
from wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors

AREA = StudyArea.polygon("POLYGON((217870 361780,218260 361780,218260 361940,217870 361940,217870 361780))",
                         "EPSG:5187")


class Recorder(Feedback):
    def __init__(self):
        self.infos, self.warnings = [], []

    def info(self, message):
        self.infos.append(message)

    def warning(self, message):
        self.warnings.append(message)


def in_subprocess(code: str, shape_encoding: str | None = "") -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh Python with the core importable and GDAL configured as QGIS configures it
    (``SHAPE_ENCODING=""``: no recoding), so that a crash fails the test instead of killing pytest."""
    prelude = "from osgeo import gdal\n" + (
        f"gdal.SetConfigOption('SHAPE_ENCODING', {shape_encoding!r})\n" if shape_encoding is not None else "")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-X", "faulthandler", "-c", prelude + textwrap.dedent(code)],
                          capture_output=True, text=True, env=env, timeout=300, check=False)


def _json(result: subprocess.CompletedProcess):
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-3000:]}"
    return json.loads(result.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def layers(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("ngii")
    made = {"buildings": ngii.buildings(folder / "euckr"), "buildings_cp949": ngii.buildings(folder / "cp949", "CP949"),
            "buildings_nocpg": ngii.buildings(folder / "nocpg", None), "roads": ngii.road_polygons(folder / "roads"),
            "lines": ngii.centre_lines(folder / "lines"), "dem": ngii.dem(folder / "dem.tif")}
    dbf = made["buildings"].with_suffix(".dbf").read_bytes()
    assert "층수".encode("cp949") in dbf and "똠방각하".encode("cp949") in dbf  # CP949 bytes, as NGII ships them
    return made


# -- no crash, whatever the encoding and the field names ------------------------------------------

def test_gdal_36_arrow_reader_crashes_on_such_a_layer_and_arrow_ready_refuses_it(layers):
    """The hazard itself: QGIS's SHAPE_ENCODING="" leaves the CP949 field names undecoded, and GDAL 3.6's
    Arrow reader dies on them (SIGSEGV), not with an exception. ``arrow_ready`` sends such layers to
    the feature API."""
    raw = in_subprocess(f"""
        from osgeo import ogr
        ds = ogr.Open({str(layers['buildings'])!r})
        for batch in ds.GetLayer(0).GetArrowStreamAsNumPy():
            pass
        """)
    if gdal.VersionInfo() < "3070000":
        assert raw.returncode == -signal.SIGSEGV, raw.stderr[-2000:]
        assert "GetNextRecordBatch" in raw.stderr
    guarded = _json(in_subprocess(f"""
        import json
        from osgeo import ogr
        from wit_plugin.infra.io import bulk_read
        ds = ogr.Open({str(layers['buildings'])!r})
        layer = ds.GetLayer(0)
        names = [layer.GetLayerDefn().GetFieldDefn(i).GetName() for i in range(8)]
        batch = next(bulk_read.batches(layer, fid=True))
        print(json.dumps([bulk_read.arrow_ready(layer), [bulk_read.is_utf8(n) for n in names], len(batch["fid"]),
                          [v.decode("cp949") for v in batch[names[3]].tolist()][:2]]))
        """))
    assert guarded == [False, [False] * 7 + [True], 12, ngii.USES[:2]]


READ_EVERY_WAY = """
    import json
    import numpy as np
    from wit_plugin.infra.io import bulk_read, vector_io
    path = {path!r}
    plain = vector_io.read_layer(path)
    near = vector_io.read_layer(path, bbox=(217890.0, 361790.0, 217980.0, 361900.0))
    ds, layer, names = vector_io.open_step_layer(path, "buildings", "prepared buildings (wit:preparevectors)",
                                                 ("층수", "용도"))
    batches = list(bulk_read.batches(layer, fid=True))
    floors = np.concatenate([b["층수"] for b in batches]).tolist()
    uses = [t for b in batches for t in bulk_read.texts(b["용도"])]
    print(json.dumps({{"fields": [f.name for f in plain.fields], "encoding": plain.encoding,
                      "uses": plain.columns["용도"], "names": plain.columns["명칭"], "floors": plain.columns["층수"],
                      "near": len(near), "step_names": names, "step_floors": floors, "step_uses": uses,
                      "arrow": bulk_read.arrow_ready(layer)}}, ensure_ascii=False))
    """


@pytest.mark.parametrize("shape_encoding", ["", None], ids=["qgis", "plain-gdal"])
@pytest.mark.parametrize("variant", ["buildings", "buildings_cp949", "buildings_nocpg"])
def test_korean_field_names_read_every_way_without_a_crash(layers, variant, shape_encoding):
    """EUC-KR or CP949 .cpg, or none; under QGIS's settings and plain GDAL: the names and values are the
    Korean text, through read_layer (with and without a bounding box) and the step readers (bulk_read)."""
    found = _json(in_subprocess(READ_EVERY_WAY.format(path=str(layers[variant])), shape_encoding))
    names = [name for name, _, _ in ngii.BUILDING_FIELDS]
    assert found["fields"] == names and found["step_names"] == names
    assert found["encoding"] == "CP949"
    assert found["uses"] == found["step_uses"] == ngii.USES
    assert found["names"] == [n or None for n in ngii.NAMES]  # 똠 decodes: CP949, not EUC-KR
    assert found["floors"] == found["step_floors"] == ngii.FLOORS
    assert found["near"] == 4  # the buildings of the west block that meet the box
    assert found["arrow"] is True  # opened with an explicit encoding, the names are UTF-8: the fast path


def test_a_declared_euc_kr_that_holds_cp949_syllables_is_read_as_cp949_with_a_warning(layers):
    feedback = Recorder()
    layer = vector_io.read_layer(layers["buildings"], feedback=feedback)
    assert layer.columns["명칭"][0] == "똠방각하"
    assert any("its .cpg file says EUC-KR, which does not decode its text; read as CP949" in w
               for w in feedback.warnings)
    assert vector_io.shapefile_encoding(layers["buildings_cp949"]) == "CP949"
    assert vector_io.shapefile_encoding(layers["buildings_nocpg"]) == "CP949"


def test_korean_field_names_with_ascii_text_are_still_decoded(tmp_path):
    """Names alone decide too: every value ASCII, the names Korean (the sniff reads the DBF header)."""
    path = ngii.write_shapefile(tmp_path / "n.shp", ogr.wkbPolygon,
                                [("층수", ogr.OFTInteger, 10), ("구분", ogr.OFTString, 10)],
                                [{"층수": 3, "구분": "A1"}], [ngii.building_wkt(0, 0)], cpg=None)
    found = _json(in_subprocess(f"""
        import json
        from wit_plugin.infra.io import vector_io
        layer = vector_io.read_layer({str(path)!r})
        print(json.dumps([[f.name for f in layer.fields], layer.columns["층수"], layer.encoding], ensure_ascii=False))
        """))
    assert found == [["층수", "구분"], [3], "CP949"]


def test_a_csv_with_cp949_field_names_is_read_feature_by_feature(tmp_path):
    """A format GDAL does not recode (CSV): the names are not UTF-8, so the Arrow reader is never
    asked; the feature API reads it and the names and values are decoded, with a warning."""
    path = tmp_path / "건물.csv"
    path.write_bytes('WKT,층수,용도\n"POLYGON((0 0,10 0,10 10,0 10,0 0))",3,단독주택\n'.encode("cp949"))
    found = _json(in_subprocess(f"""
        import json
        from wit_plugin.infra.io import vector_io
        from wit_plugin.infra.feedback import Feedback
        class F(Feedback):
            warnings = []
            def warning(self, message):
                self.warnings.append(message)
        feedback = F()
        layer = vector_io.read_layer({str(path)!r}, crs="EPSG:5187", feedback=feedback)
        print(json.dumps([[f.name for f in layer.fields], layer.columns["용도"], layer.geoms[0].area,
                          feedback.warnings], ensure_ascii=False))
        """))
    assert found[:3] == [["WKT", "층수", "용도"], ["단독주택"], 100.0]
    assert found[3] == ["건물.csv: 2 field name(s) are not UTF-8 (read as 층수, 용도); "
                        "the layer is read feature by feature."]


def test_the_feature_api_gives_the_arrow_readers_columns(tmp_path):
    """``bulk_read.feature_batches`` (the fallback) yields what the Arrow reader yields: keys, numbers,
    NULL masks, text bytes, WKB."""
    path = tmp_path / "t.gpkg"
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer("t", ngii.srs(), ogr.wkbPolygon)
    for name, kind in (("n", ogr.OFTInteger), ("r", ogr.OFTReal), ("s", ogr.OFTString)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    for k in range(5):
        feature = ogr.Feature(layer.GetLayerDefn())
        if k % 2:
            feature.SetField("n", k)
            feature.SetField("s", "도로" * k)
        feature.SetField("r", k / 4)
        feature.SetGeometry(ogr.CreateGeometryFromWkt(ngii.building_wkt(k, k, 1 + k)))
        layer.CreateFeature(feature)
    del layer, ds
    ds = ogr.Open(str(path))
    arrow = list(bulk_read.batches(ds.GetLayer(0), size=2, fid=True))
    features = list(bulk_read.feature_batches(ds.GetLayer(0), size=2, fid=True))
    assert len(arrow) == len(features) == 3
    for a, f in zip(arrow, features):
        assert set(a) == set(f) == {"fid", "geometry", "n", "r", "s"}
        for key in ("fid", "n", "r", "s"):
            assert np.ma.getmaskarray(a[key]).tolist() == np.ma.getmaskarray(f[key]).tolist(), key
            assert a[key].tolist() == f[key].tolist(), key
        assert [bytes(w) for w in a["geometry"]] == list(f["geometry"])


# -- any layer of a file --------------------------------------------------------------------------

def test_a_step_takes_a_files_only_layer_its_own_name_or_the_named_one(tmp_path):
    one = tmp_path / "footprints.gpkg"
    two = tmp_path / "two.gpkg"
    for path, names in ((one, ["houses"]), (two, ["buildings", "other"])):
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
        for name in names:
            layer = ds.CreateLayer(name, ngii.srs(), ogr.wkbPolygon)
            feature = ogr.Feature(layer.GetLayerDefn())
            feature.SetGeometry(ogr.CreateGeometryFromWkt(ngii.building_wkt(0, 0, 1 + len(name))))
            layer.CreateFeature(feature)
        del layer, ds
    assert vector_io.read_prepared(str(one), "buildings").name == "houses"  # the only layer
    assert vector_io.read_prepared(str(two), "buildings").name == "buildings"  # the step's name
    assert vector_io.read_prepared(f"{two}|layername=other", "buildings").geoms[0].area == 36.0
    assert vector_io.read_prepared(f"{two}|layerid=1", "buildings").name == "other"
    with pytest.raises(InputError, match=r"two.gpkg has no layer 'lod1_faces' and holds 2 layers \(buildings, other\): "
                                         r"name the one to use, as two.gpkg\|layername=<name>"):
        vector_io.read_prepared(str(two), "lod1_faces")
    with pytest.raises(InputError, match=r"lacks the field\(s\) wit_face of the LoD1 faces \(wit:extrudebuildings\)"):
        vector_io.open_step_layer(str(one), step_layers.LOD1_LAYER, step_layers.LOD1_ROLE, (step_layers.FACE_TYPE,))


# -- road schemas ---------------------------------------------------------------------------------

@pytest.mark.parametrize("fields,row,expected", [
    ([n for n, _, _ in ngii.CENTRE_LINE_FIELDS], {"도로폭": 12.0, "차로수": 4}, (12.0, "도로폭")),
    ([n for n, _, _ in ngii.CENTRE_LINE_FIELDS], {"도로폭": 0.0, "차로수": 2}, (6.5, "차로수 × 3.25 m")),
    ([n for n, _, _ in ngii.CENTRE_LINE_FIELDS], {"도로폭": None, "차로수": None}, (6.0, "default")),
    (["UFID", "ROAD_NO", "ROAD_SE", "CARTRK_CO", "ROAD_BT"], {"ROAD_BT": 8.5, "CARTRK_CO": 2}, (8.5, "ROAD_BT")),
    (["UFID", "ROAD_NO", "ROAD_SE", "CARTRK_CO", "ROAD_BT"], {"ROAD_BT": None, "CARTRK_CO": 3},
     (9.75, "CARTRK_CO × 3.25 m")),
    (["UFID", "RDNU", "NAME", "RDDV", "RDLN", "RVWD"], {"RVWD": "15", "RDLN": 4}, (15.0, "RVWD")),
    (["UFID", "RDNU", "NAME", "RDDV", "RDLN", "RVWD"], {"RVWD": None, "RDLN": "2"}, (6.5, "RDLN × 3.25 m")),
    (["SIG_CD", "RDS_MAN_NO", "ROA_CLS_SE", "ROAD_BT"], {"ROAD_BT": 0, "ROA_CLS_SE": "3"}, (12.0, "ROA_CLS_SE=3")),
    (["osm_id", "highway", "width", "lanes"], {"highway": "primary", "width": "7.5 m", "lanes": "2"}, (7.5, "width")),
    (["osm_id", "highway", "width", "lanes"], {"highway": "primary", "width": None, "lanes": "3"},
     (9.75, "lanes × 3.25 m")),
    (["osm_id", "highway", "width", "lanes"], {"highway": "residential", "width": "", "lanes": "2;3"},
     (6.5, "highway=residential")),
    (["osm_id", "highway"], {"highway": "footway"}, (2.0, "highway=footway")),
    (["id", "name"], {}, (6.0, "default")),
])
def test_road_width_rules_of_the_known_schemas(fields, row, expected):
    width, source = roads.WidthRule.of(fields, 6.0).width_of(row)
    assert (width, source) == (pytest.approx(expected[0]), expected[1])


def test_the_rule_says_which_schema_each_layer_got():
    describe = {label: roads.WidthRule.of(fields, 6.0).describe() for label, fields in (
        ("ngii", [n for n, _, _ in ngii.CENTRE_LINE_FIELDS]), ("osm", ["highway", "width", "lanes"]),
        ("juso", ["RDS_MAN_NO", "ROA_CLS_SE", "ROAD_BT"]), ("other", ["id"]))}
    assert describe == {
        "ngii": "NGII digital map road centre lines (N3L_A0020000, Korean field names): 도로폭 (m) → 차로수 × 3.25 m → "
                "default 6 m",
        "osm": "OpenStreetMap roads: width (m) → lanes × 3.25 m → highway class default → default 6 m",
        "juso": "road-name-address roads (TL_SPRD_MANAGE): ROAD_BT (m) → ROA_CLS_SE class default → default 6 m",
        "other": "line layer without a known width field: default 6 m"}


# -- road polygons and centre lines through wit:preparevectors ------------------------------------

def _table(path: Path, name: str) -> list[dict]:
    ds = ogr.Open(str(path))
    layer = ds.GetLayerByName(name)
    return [{**feature.items(), "geometry": shapely.from_wkb(bytes(feature.GetGeometryRef().ExportToIsoWkb()))
             if feature.GetGeometryRef() else None} for feature in layer]


def test_ngii_road_polygons_are_the_road_surfaces_as_they_are(layers, tmp_path):
    feedback = Recorder()
    out = tmp_path / "prepared.gpkg"
    report = prepare_vectors(layers["buildings_nocpg"], layers["roads"], None, AREA, out,
                             PrepareConfig(target_crs="EPSG:5187"), feedback)
    stats = {s.layer: s for s in report.stats}
    assert (stats["roads"].features_in, stats["roads"].features_out, stats["buildings"].features_out) == (2, 2, 12)
    rows = _table(out, step_layers.PREPARED_ROADS)
    assert [r[step_layers.ROAD_WIDTH_SOURCE] for r in rows] == ["surface", "surface"]
    assert [r[step_layers.ROAD_WIDTH] for r in rows] == [None, None]
    assert [r["명칭"] for r in rows] == ["화랑로", None]
    assert [r[step_layers.WIT_ID] for r in rows] == ["RD_A0012021359010580000001", "RD_A0012021359010580000002"]
    expected = [shapely.from_wkt(w).intersection(report.area) for w in ngii.ROAD_POLYGONS]
    for row, polygon in zip(rows, expected):  # cut to the area, not simplified: the same shape, the same vertices
        assert row["geometry"].symmetric_difference(polygon).area < 1e-6
        assert shapely.get_num_coordinates(row["geometry"]) == shapely.get_num_coordinates(polygon)
    assert any("2 road polygon(s) of N3A_A0010000.shp are road surfaces as they are" in m for m in feedback.infos)
    buildings = _table(out, step_layers.PREPARED_BUILDINGS)
    assert [b["층수"] for b in buildings] == ngii.FLOORS and [b["용도"] for b in buildings] == ngii.USES
    assert buildings[0][step_layers.WIT_ID].startswith("BLD_B0012021")
    assert not any("fields not found" in w for w in feedback.warnings)  # not a road-name-address layer


def test_ngii_centre_lines_are_buffered_by_their_width_or_lanes(layers, tmp_path):
    feedback = Recorder()
    out = tmp_path / "lines.gpkg"
    prepare_vectors(None, layers["lines"], None, AREA, out, PrepareConfig(target_crs="EPSG:5187", road_tolerance=0.0),
                    feedback)
    rows = {r["UFID"]: r for r in _table(out, step_layers.PREPARED_ROADS)}
    assert {k: (r[step_layers.ROAD_WIDTH], r[step_layers.ROAD_WIDTH_SOURCE]) for k, r in rows.items()} == {
        "A0022021359010580000001": (12.0, "도로폭"), "A0022021359010580000002": (6.5, "차로수 × 3.25 m"),
        "A0022021359010580000003": (6.0, "default")}
    # the 12 m road: 12 m wide, with round caps of 6 m at both ends
    wide = rows["A0022021359010580000001"]["geometry"]
    assert shapely.bounds(wide).tolist() == pytest.approx([217874.0, 361872.0, 218256.0, 361884.0], abs=0.01)
    assert ("Road width rule: NGII digital map road centre lines (N3L_A0020000, Korean field names): 도로폭 (m) → "
            "차로수 × 3.25 m → default 6 m; 1 from 도로폭, 1 from 차로수 × 3.25 m, 1 from default") in feedback.infos
    assert ("roads: 1 of 3 centre line(s) have no width, lane count or known class: buffered with the default width "
            "6 m.") in feedback.warnings


def test_a_road_layer_of_lines_and_polygons_keeps_both(tmp_path):
    """An OpenStreetMap export with highway lines and area:highway polygons in one layer."""
    path = tmp_path / "osm.gpkg"
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer("roads", ngii.srs(), ogr.wkbUnknown)
    for name in ("osm_id", "highway", "width"):
        layer.CreateField(ogr.FieldDefn(name, ogr.OFTString))
    for osm_id, highway, width, wkt in (("11", "secondary", None, "LINESTRING(217900 361830,218200 361830)"),
                                        ("12", "service", "4 m", "LINESTRING(217950 361800,217950 361860)"),
                                        ("13", "pedestrian", None, ngii.ROAD_POLYGONS[0])):
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField("osm_id", osm_id)
        feature.SetField("highway", highway)
        feature.SetField("width", width)
        feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
        layer.CreateFeature(feature)
    del layer, ds
    out = tmp_path / "prepared.gpkg"
    report = prepare_vectors(None, str(path), None, AREA, out, PrepareConfig(target_crs="EPSG:5187"))
    rows = _table(out, step_layers.PREPARED_ROADS)
    assert sorted((r["osm_id"], r[step_layers.ROAD_WIDTH], r[step_layers.ROAD_WIDTH_SOURCE]) for r in rows) == [
        ("11", 12.0, "highway=secondary"), ("12", 4.0, "width"), ("13", None, "surface")]
    assert len({r[step_layers.WIT_ID] for r in rows}) == 3
    assert report.stats[0].features_in == 3 and report.stats[0].features_out == 3
