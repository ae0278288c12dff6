"""wit_plugin.citygml: a small city (two touching LoD1 boxes, one with a courtyard, a TIN with a
road, two districts, two texture images) written, schema-validated and checked value by value."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from lxml import etree
from osgeo import gdal, ogr, osr

from wit_plugin.citygml import inputs as citygml_inputs
from wit_plugin.citygml import writer as citygml
from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.texture import TEXCOORDS_FILE

NS = citygml.NS
ROAD = "RD_11110_3000001"
NASTY = 'a<b & "c" \x01d\x1f'  # XML specials + control characters

# building A: box 209000–209020.9 × 543120–543132.8, base 10.0, height 8.6 → roof at 18.6
A = dict(wit_id="BLD_1111010100100010000000001", outer=[(209000, 543120), (209020.9, 543120),
                                                         (209020.9, 543132.8), (209000, 543132.8)],
         holes=[], base=10.0, height=8.6, src="field", attrs={"BULD_NM": "서울특별시청", "GRND_FLR": 3,
                                                               "AREA": 267.52, "NOTE": NASTY})
# building B touches A along x = 209020.9 and has a courtyard; its height is the default
B = dict(wit_id="BLD_1111010100100010000000002", outer=[(209020.9, 543120), (209040, 543120),
                                                         (209040, 543132.8), (209020.9, 543132.8)],
         holes=[[(209026, 543124), (209026, 543128), (209034, 543128), (209034, 543124)]],
         base=10.5, height=3.0, src="default", attrs={"BULD_NM": "덕수궁 별관", "GRND_FLR": None,
                                                         "AREA": float("nan"), "NOTE": None})


def _ring(points, z):
    return [(x, y, z) for x, y in points] + [(points[0][0], points[0][1], z)]


def _signed_area(points) -> float:
    return sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(points, points[1:] + points[:1])) / 2


def _ccw(points):
    return points if _signed_area(points) > 0 else points[::-1]


def extrude(outer, holes, base, top):
    """Faces as wit:extrudebuildings makes them: ground CW from above, roof CCW, walls outward."""
    outer, holes = _ccw(outer), [_ccw(h)[::-1] for h in holes]  # exterior CCW, holes CW (from above)
    faces = [("ground", [_ring(outer[::-1], base)] + [_ring(h[::-1], base) for h in holes]),
             ("roof", [_ring(outer, top)] + [_ring(h, top) for h in holes])]
    for ring in [outer] + holes:
        for (x0, y0), (x1, y1) in zip(ring, ring[1:] + ring[:1]):
            faces.append(("wall", [[(x0, y0, base), (x1, y1, base), (x1, y1, top), (x0, y0, top), (x0, y0, base)]]))
    return faces


def _polygon(rings) -> ogr.Geometry:
    polygon = ogr.Geometry(ogr.wkbPolygon)
    for points in rings:
        ring = ogr.Geometry(ogr.wkbLinearRing)
        for point in points:
            ring.AddPoint(*point) if len(point) == 3 else ring.AddPoint_2D(*point)
        polygon.AddGeometry(ring)
    return polygon


def _layer(path: Path, name: str, geom_type: int, fields: dict[str, int]) -> tuple[ogr.DataSource, ogr.Layer]:
    ds = ogr.Open(str(path), 1) if path.exists() else ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    layer = ds.CreateLayer(name, srs if geom_type != ogr.wkbNone else None, geom_type)
    for field_name, field_type in fields.items():
        layer.CreateField(ogr.FieldDefn(field_name, field_type))
    return ds, layer


def _add(layer: ogr.Layer, geometry: ogr.Geometry | None, **values) -> None:
    feature = ogr.Feature(layer.GetLayerDefn())
    for key, value in values.items():
        if value is not None:
            feature.SetField(key, value)
    if geometry is not None:
        feature.SetGeometry(geometry)
    layer.CreateFeature(feature)


def make_inputs(folder: Path) -> citygml.CityGMLInputs:
    folder.mkdir(parents=True, exist_ok=True)
    ds, layer = _layer(folder / "lod1.gpkg", step_layers.LOD1_LAYER, ogr.wkbPolygon25D, {
        step_layers.WIT_ID: ogr.OFTString, step_layers.FACE_TYPE: ogr.OFTString,
        step_layers.FACE_NUMBER: ogr.OFTInteger, step_layers.BASE_Z: ogr.OFTReal, step_layers.HEIGHT: ogr.OFTReal,
        step_layers.HEIGHT_SOURCE: ogr.OFTString,
        step_layers.STOREYS_ABOVE: ogr.OFTInteger, step_layers.STOREYS_BELOW: ogr.OFTInteger,
        "BULD_NM": ogr.OFTString, "GRND_FLR": ogr.OFTInteger, "AREA": ogr.OFTReal, "NOTE": ogr.OFTString})
    rows = []
    for b in (A, B):
        for number, (kind, rings) in enumerate(extrude(b["outer"], b["holes"], b["base"], b["base"] + b["height"])):
            rows.append((b, number, kind, rings))
    rows = rows[1::2] + rows[::2]  # stored out of order: the writer must sort by wit_id, face_no
    for b, number, kind, rings in rows:
        _add(layer, _polygon(rings), **{step_layers.WIT_ID: b["wit_id"], step_layers.FACE_TYPE: kind,
                                        step_layers.FACE_NUMBER: number, step_layers.BASE_Z: b["base"],
                                        step_layers.HEIGHT: b["height"], step_layers.HEIGHT_SOURCE: b["src"],
                                        step_layers.STOREYS_ABOVE: 3 if b is A else None,
                                        step_layers.STOREYS_BELOW: 1 if b is A else None}, **b["attrs"])
    ds = None
    # TIN over 208990–209050 × 543110–543140: a road strip y < 543118 (two triangles), terrain above
    ds, layer = _layer(folder / "tin.gpkg", step_layers.TIN_LAYER, ogr.wkbPolygon25D, {
        step_layers.TIN_TRIANGLE_ID: ogr.OFTInteger, step_layers.TIN_SURFACE: ogr.OFTString,
        step_layers.TIN_FEATURE_ID: ogr.OFTString})
    z = {543110: 9.5, 543118: 9.8, 543140: 10.2}
    tris = [(1, "road", ROAD, [(208990, 543110), (209050, 543110), (209050, 543118)]),
            (2, "road", ROAD, [(208990, 543110), (209050, 543118), (208990, 543118)]),
            (3, "terrain", None, [(208990, 543118), (209050, 543118), (209050, 543140)]),
            (4, "terrain", None, [(208990, 543118), (209050, 543140), (208990, 543140)]),
            (5, "footprint", A["wit_id"], [(209000, 543120), (209020.9, 543120), (209020.9, 543132.8)])]
    for tri_id, surface, feature_id, points in tris:
        _add(layer, _polygon([[(x, y, z.get(y, 10.0)) for x, y in points + points[:1]]]),
             **{step_layers.TIN_TRIANGLE_ID: tri_id, step_layers.TIN_SURFACE: surface,
                step_layers.TIN_FEATURE_ID: feature_id})
    ds = None
    ds, layer = _layer(folder / "roads.gpkg", step_layers.PREPARED_ROADS, ogr.wkbPolygon, {
        step_layers.WIT_ID: ogr.OFTString, "RN": ogr.OFTString, "ROAD_BT": ogr.OFTReal,
        step_layers.ROAD_WIDTH_SOURCE: ogr.OFTString})
    _add(layer, _polygon([[(208990, 543110), (209050, 543110), (209050, 543118), (208990, 543118), (208990, 543110)]]),
         **{step_layers.WIT_ID: ROAD, "RN": "세종대로", "ROAD_BT": 8.0, step_layers.ROAD_WIDTH_SOURCE: "ROAD_BT"})
    ds = None
    ds, layer = _layer(folder / "districts.gpkg", step_layers.PREPARED_DISTRICTS, ogr.wkbPolygon, {
        step_layers.WIT_ID: ogr.OFTString, "EMD_CD": ogr.OFTString, "EMD_KOR_NM": ogr.OFTString})
    for code, name, x0, x1 in (("11110101", "청운동", 208900, 209025), ("11110102", "신교동", 209025, 209100),
                               ("11110103", "궁정동", 209100, 209200)):
        _add(layer, _polygon([[(x0, 543000), (x1, 543000), (x1, 543200), (x0, 543200), (x0, 543000)]]),
             **{step_layers.WIT_ID: f"EMD_{code}", "EMD_CD": code, "EMD_KOR_NM": name})
    ds = None
    tex = folder / "textures"
    (tex / "atlas").mkdir(parents=True)
    mem = gdal.GetDriverByName("MEM").Create("", 8, 8, 3)
    gdal.GetDriverByName("JPEG").CreateCopy(str(tex / "atlas" / "roofs.jpg"), mem)
    gdal.GetDriverByName("PNG").CreateCopy(str(tex / "ground.png"), mem)
    ds, layer = _layer(tex / TEXCOORDS_FILE, step_layers.TEXCOORD_TABLE, ogr.wkbNone, {
        step_layers.TEX_TARGET: ogr.OFTString, step_layers.TEX_FEATURE: ogr.OFTString,
        step_layers.TEX_FACE: ogr.OFTInteger, step_layers.TEX_IMAGE: ogr.OFTString,
        step_layers.TEX_COORDS: ogr.OFTString})
    for target, feature, face, image, uv in (
            ("roof", A["wit_id"], 1, "atlas/roofs.jpg", "0 0 0.5 0 0.5 0.5 0 0.5 0 0"),
            ("roof", B["wit_id"], 1, "atlas/roofs.jpg", "0.5 0 1 0 1 0.5 0.5 0.5 0.5 0"),
            ("tin", "3", None, "ground.png", "0 0 1 0 1 1 0 0"),
            ("tin", "4", None, "ground.png", "0 0 1 1 0 1 0 0"),
            ("road", "1", None, "ground.png", "0 0 1 0 1 0.25 0 0")):
        _add(layer, None, **{step_layers.TEX_TARGET: target, step_layers.TEX_FEATURE: feature,
                             step_layers.TEX_FACE: face, step_layers.TEX_IMAGE: image, step_layers.TEX_COORDS: uv})
    del ds  # close: flush to disk
    return citygml.CityGMLInputs(lod1=str(folder / "lod1.gpkg"), tin=str(folder / "tin.gpkg"),
                                 roads=str(folder / "roads.gpkg"), districts=str(folder / "districts.gpkg"),
                                 textures=str(tex))


@pytest.fixture(scope="module")
def schema(shared_dir) -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(shared_dir / "schemas" / "citygml3-all.xsd")))


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    folder = tmp_path_factory.mktemp("city")
    inputs = make_inputs(folder / "in")
    out = folder / "out" / "city.gml"
    report = citygml.write_citygml(inputs, str(out))
    return inputs, out, report, etree.parse(str(out))


def _all(doc, path: str) -> list:
    return doc.xpath(path, namespaces=NS)


def test_valid_against_citygml3_schema(written, schema, shared_dir):
    _, out, _, doc = written
    assert schema.validate(doc), [f"{e.line}: {e.message}" for e in schema.error_log]
    if shutil.which("xmllint") is None:
        pytest.skip("xmllint not installed")
    run = subprocess.run(["xmllint", "--nonet", "--noout", "--schema",
                          str(shared_dir / "schemas" / "citygml3-all.xsd"), str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


def test_counts_and_report(written):
    _, _, report, doc = written
    assert len(_all(doc, "//bldg:Building")) == 2
    assert len(_all(doc, "//bldg:Building/core:lod1Solid/gml:Solid")) == 2
    faces_a, faces_b = 2 + 4, 2 + 4 + 4
    assert len(_all(doc, f"//bldg:Building[@gml:id='{A['wit_id']}']//gml:surfaceMember")) == faces_a
    assert len(_all(doc, f"//bldg:Building[@gml:id='{B['wit_id']}']//gml:surfaceMember")) == faces_b
    assert len(_all(doc, "//tran:Road")) == 1
    assert len(_all(doc, "//tran:TrafficArea/core:lod2MultiSurface//gml:Polygon")) == 2
    assert len(_all(doc, "//dem:TINRelief//gml:Triangle")) == 3  # terrain 3, 4 and footprint 5
    assert len(_all(doc, "//app:ParameterizedTexture")) == 2
    assert [g.get(f"{{{NS['gml']}}}id") for g in _all(doc, "//grp:CityObjectGroup")] == ["EMD_11110101", "EMD_11110102"]
    assert report.buildings == 2 and report.faces == faces_a + faces_b and report.roads == 1
    assert report.triangles == 5 and report.textures == 2 and report.textured_surfaces == 5
    assert report.groups == 2 and report.group_members == 2
    assert report.envelope == pytest.approx((208990, 543110, 9.5, 209050, 543140, 18.6))
    assert _all(doc, "/core:CityModel/gml:boundedBy/gml:Envelope/gml:lowerCorner/text()") == [
        "208990.000 543110.000 9.500"]
    assert _all(doc, "/core:CityModel/gml:boundedBy/gml:Envelope/@srsName") == ["EPSG:5186"]  # easting first


def test_gdal_reads_the_written_coordinates_as_written(written, tmp_path):
    """QGIS opens model.gml through GDAL's GML reader, which reads an EPSG URN or URL in EPSG's axis order
    (northing first for EPSG:5186) and the short form EPSG:n easting first: the model lands where it is."""
    _, out, _, _ = written
    copy = Path(shutil.copy(out, tmp_path / "city.gml"))  # GDAL writes a .gfs beside what it reads
    ds = gdal.OpenEx(str(copy), gdal.OF_VECTOR)
    xmin, xmax, ymin, ymax = ds.GetLayerByName("Road").GetExtent()
    assert (xmin, ymin) == pytest.approx((208990, 543110), abs=50) and xmax < 300000 < ymax
    del ds


def test_building_content(written):
    _, _, _, doc = written
    a = _all(doc, f"//bldg:Building[@gml:id='{A['wit_id']}']")[0]
    roof = _all(a, f".//gml:Polygon[@gml:id='{A['wit_id']}_f1']//gml:posList/text()")[0]
    assert "209020.900 543132.800 18.600" in roof
    assert [c.tag.split("}")[1] for c in a][-4:] == ["lod1Solid", "height", "storeysAboveGround", "storeysBelowGround"]
    assert _all(a, "con:height/con:Height/con:value/text()") == ["8.600"]
    assert _all(a, "con:height/con:Height/con:status/text()") == ["measured"]
    attrs = {n: (v, t.split("}")[1]) for t, n, v in (
        (g.tag, g[0].text, g[1].text) for g in _all(a, "core:genericAttribute/*"))}
    assert attrs["BULD_NM"] == ("서울특별시청", "StringAttribute")
    assert attrs["GRND_FLR"] == ("3", "IntAttribute")
    assert attrs["AREA"] == ("267.52", "DoubleAttribute")
    assert attrs["NOTE"] == ('a<b & "c" d', "StringAttribute")  # control characters dropped
    assert attrs[step_layers.HEIGHT_SOURCE] == ("field", "StringAttribute")
    b = _all(doc, f"//bldg:Building[@gml:id='{B['wit_id']}']")[0]
    names = _all(b, "core:genericAttribute/*/gen:name/text()")
    assert "AREA" not in names and "NOTE" not in names and "GRND_FLR" not in names  # NaN / NULL omitted
    assert _all(b, f"core:genericAttribute/*[gen:name='{step_layers.HEIGHT_SOURCE}']/gen:value/text()") == ["default"]
    assert _all(b, "con:height/con:Height/con:status/text()") == ["estimated"]
    assert not _all(b, "bldg:storeysAboveGround")
    assert _all(b, f".//gml:Polygon[@gml:id='{B['wit_id']}_f1']/gml:interior/gml:LinearRing/@gml:id") == [
        f"{B['wit_id']}_f1_r1"]
    # face order follows face_no, although the faces were stored shuffled
    ids = _all(b, ".//gml:surfaceMember/gml:Polygon/@gml:id")
    assert ids == [f"{B['wit_id']}_f{n}" for n in range(10)]


def test_raw_text_is_escaped(written):
    _, out, _, _ = written
    raw = out.read_text(encoding="utf-8")
    assert "a&lt;b &amp; \"c\" d" in raw and "\x01" not in raw and "서울특별시청" in raw


def test_road_and_relief(written):
    _, _, _, doc = written
    road = _all(doc, f"//tran:Road[@gml:id='{ROAD}']")[0]
    attrs = dict(zip(_all(road, "core:genericAttribute/*/gen:name/text()"),
                     _all(road, "core:genericAttribute/*/gen:value/text()")))
    assert attrs["RN"] == "세종대로" and attrs["ROAD_BT"] == "8.0"
    assert _all(road, ".//gml:Polygon/@gml:id") == ["tri_1", "tri_2"]
    assert _all(road, ".//gml:Polygon[@gml:id='tri_1']//gml:posList/text()") == [
        "208990.000 543110.000 9.500 209050.000 543110.000 9.500 209050.000 543118.000 9.800 "
        "208990.000 543110.000 9.500"]
    rings = _all(doc, "//dem:TINRelief//gml:Triangle/gml:exterior/gml:LinearRing/@gml:id")
    assert rings == ["tri_3_r", "tri_4_r", "tri_5_r"]


def _tin_copy(source: str, target: Path, order, extra=()) -> str:
    """The TIN's rows written again in ``order`` (of their tri_ids), then the ``extra`` ones (tri_id, surface, feature
    id, z): the table's own order then differs from the tri_ids' or not."""
    src = ogr.Open(source)
    rows = {f.GetField(step_layers.TIN_TRIANGLE_ID): f for f in src.GetLayer()}
    ds, layer = _layer(target, step_layers.TIN_LAYER, ogr.wkbPolygon25D, {
        step_layers.TIN_TRIANGLE_ID: ogr.OFTInteger, step_layers.TIN_SURFACE: ogr.OFTString,
        step_layers.TIN_FEATURE_ID: ogr.OFTString})
    for tri_id in order:
        row = rows[tri_id]
        _add(layer, row.GetGeometryRef().Clone(), **{name: row.GetField(name) for name in (
            step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE, step_layers.TIN_FEATURE_ID)})
    for tri_id, surface, feature_id, z in extra:
        _add(layer, _polygon([[(209030, 543130, z), (209040, 543130, z), (209040, 543135, z), (209030, 543130, z)]]),
             **{step_layers.TIN_TRIANGLE_ID: tri_id, step_layers.TIN_SURFACE: surface,
                step_layers.TIN_FEATURE_ID: feature_id})
    del layer, ds  # (closed: written)
    return str(target)


def test_the_relief_is_the_same_read_from_the_table_or_sorted_by_sqlite(written, tmp_path):
    """The relief is read from the TIN table when its rows come in tri_id order (as the terrain step writes them),
    else sorted by SQLite: the same bytes either way; a triangle with a road's id and no surface is in neither the
    road nor the relief (as SQL's NULL decides), one with neither is in the relief."""
    inputs = written[0]
    extra = [(6, None, ROAD, 11.0), (7, None, None, 12.0)]
    tins = {"table": _tin_copy(inputs.tin, tmp_path / "in_order.gpkg", [1, 2, 3, 4, 5], extra),
            "sqlite": _tin_copy(inputs.tin, tmp_path / "shuffled.gpkg", [4, 1, 5, 3, 2], extra[::-1])}
    in_order = {}
    for kind, path in tins.items():
        with citygml_inputs.InputLayer.open(path, step_layers.TIN_LAYER, step_layers.TIN_ROLE, ()) as tin:
            in_order[kind] = citygml_inputs.rises_in_table_order(tin, step_layers.TIN_TRIANGLE_ID)
    assert in_order == {"table": True, "sqlite": False}
    written_bytes = {}
    for kind, tin in tins.items():
        out = tmp_path / kind / "city.gml"
        citygml.write_citygml(citygml.CityGMLInputs(lod1=inputs.lod1, tin=tin, roads=inputs.roads,
                                                    districts=inputs.districts, textures=inputs.textures), str(out))
        written_bytes[kind] = out.read_bytes()
    assert written_bytes["table"] == written_bytes["sqlite"]
    doc = etree.fromstring(written_bytes["table"])
    assert _all(doc, "//dem:TINRelief//gml:Triangle/gml:exterior/gml:LinearRing/@gml:id") == [
        "tri_3_r", "tri_4_r", "tri_5_r", "tri_7_r"]
    assert _all(doc, f"//tran:Road[@gml:id='{ROAD}']//gml:Polygon/@gml:id") == ["tri_1", "tri_2"]


def test_groups(written):
    _, _, _, doc = written
    first, second = _all(doc, "//grp:CityObjectGroup")
    assert _all(first, "gml:name/text()") == ["청운동"]
    assert _all(first, "grp:groupMember/grp:Role/grp:groupMember/@xlink:href") == [f"#{A['wit_id']}"]
    assert _all(second, "grp:groupMember/grp:Role/grp:groupMember/@xlink:href") == [f"#{B['wit_id']}"]


def test_texture_targets_exist_and_match_rings(written):
    _, out, report, doc = written
    ids = {e.get(f"{{{NS['gml']}}}id"): e for e in _all(doc, "//*[@gml:id]")}
    uris = _all(doc, "//app:ParameterizedTexture/app:imageURI/text()")
    assert uris == ["city_textures/atlas/roofs.jpg", "city_textures/ground.png"]
    assert all((out.parent / uri).is_file() for uri in uris)
    assert _all(doc, "//app:ParameterizedTexture/app:mimeType/text()") == ["image/jpeg", "image/png"]
    pairs = 0
    for assoc in _all(doc, "//app:TextureAssociation"):
        assert assoc.findtext("app:target", namespaces=NS)[1:] in ids
        coords = _all(assoc, ".//app:textureCoordinates/text()")
        rings = _all(assoc, ".//app:ring/text()")
        children = [c.tag.split("}")[1] for c in _all(assoc, ".//app:TexCoordList/*")]
        assert children == ["textureCoordinates"] * len(coords) + ["ring"] * len(rings)  # coordinates first
        assert len(coords) == len(rings)
        for uv, ring in zip(coords, rings):
            points = ids[ring[1:]].findtext("gml:posList", namespaces=NS).split()
            assert len(uv.split()) // 2 == len(points) // 3
            pairs += 1
    assert pairs == report.textured_surfaces == 5
    targets = _all(doc, "//app:TextureAssociation/app:target/text()")
    assert targets == [f"#{A['wit_id']}_f1", f"#{B['wit_id']}_f1", "#tri_1", f"#{citygml.TIN_SURFACE_ID}"]


def test_stable_bytes_and_no_texture_copy(written, tmp_path):
    inputs, out, _, _ = written
    again = tmp_path / "city.gml"
    citygml.write_citygml(inputs, str(again))
    assert again.read_bytes() == out.read_bytes()
    linked = tmp_path / "linked" / "city.gml"
    citygml.write_citygml(inputs, str(linked), copy_textures=False)
    doc = etree.parse(str(linked))
    uris = _all(doc, "//app:imageURI/text()")
    assert not (linked.parent / "city_textures").exists()
    assert all(not Path(uri).is_absolute() and (linked.parent / uri).is_file() for uri in uris)


def test_minimal_input_buildings_only(written, tmp_path, schema):
    inputs, _, _, _ = written
    out = tmp_path / "only.gml"
    report = citygml.write_citygml(citygml.CityGMLInputs(lod1=inputs.lod1), str(out), srs_name="EPSG:5186")
    doc = etree.parse(str(out))
    assert schema.validate(doc), schema.error_log
    assert report.buildings == 2 and report.roads == report.triangles == report.textures == report.groups == 0
    assert report.envelope == pytest.approx((209000, 543120, 10.0, 209040, 543132.8, 18.6))


def test_input_errors(written, tmp_path):
    inputs, _, _, _ = written
    with pytest.raises(InputError, match="does not exist"):
        citygml.write_citygml(citygml.CityGMLInputs(lod1=str(tmp_path / "missing.gpkg")), str(tmp_path / "x.gml"))
    with pytest.raises(InputError,
                       match=r"lacks the field\(s\) .*wit_face.* of the LoD1 faces \(wit:extrudebuildings\)"):
        citygml.write_citygml(citygml.CityGMLInputs(lod1=inputs.roads), str(tmp_path / "x.gml"))
    with pytest.raises(InputError, match="EPSG:5186, not EPSG:5179"):
        citygml.write_citygml(citygml.CityGMLInputs(lod1=inputs.lod1), str(tmp_path / "x.gml"), srs_name="EPSG:5179")
    with pytest.raises(InputError, match="CRS"):
        citygml.write_citygml(citygml.CityGMLInputs(lod1=inputs.lod1), str(tmp_path / "x.gml"), srs_name="Korea 2000")
    assert not (tmp_path / "x.gml").exists()


@pytest.mark.parametrize("wit_id, numbers, message", [
    ("BLD 1", range(6), "cannot be a gml:id"),
    ("BLD_1", [0, 1, 2, 2, 3, 4], f"unique {step_layers.FACE_NUMBER}"),
])
def test_bad_building_ids(tmp_path, wit_id, numbers, message):
    ds, layer = _layer(tmp_path / "bad.gpkg", step_layers.LOD1_LAYER, ogr.wkbPolygon25D, {
        step_layers.WIT_ID: ogr.OFTString, step_layers.FACE_TYPE: ogr.OFTString,
        step_layers.FACE_NUMBER: ogr.OFTInteger})
    for number, (kind, rings) in zip(numbers, extrude(A["outer"], [], 0.0, 3.0)):
        _add(layer, _polygon(rings), **{step_layers.WIT_ID: wit_id, step_layers.FACE_TYPE: kind,
                                        step_layers.FACE_NUMBER: number})
    del ds  # close: flush to disk
    with pytest.raises(InputError, match=message):
        citygml.write_citygml(citygml.CityGMLInputs(lod1=str(tmp_path / "bad.gpkg")), str(tmp_path / "bad.gml"))
    assert not (tmp_path / "bad.gml").exists()


def test_cancel_leaves_no_output(written, tmp_path, monkeypatch):
    inputs, _, _, _ = written

    class Cancel(Feedback):
        def is_canceled(self) -> bool:
            return True

    monkeypatch.setattr(citygml, "_BATCH", 1)
    with pytest.raises(CanceledError):
        citygml.write_citygml(inputs, str(tmp_path / "c.gml"), feedback=Cancel())
    assert list(tmp_path.iterdir()) == []


def test_the_srs_name_says_easting_first_as_the_coordinates_are_written():
    """EPSG:5186's axis order is northing, easting: its URN and URL forms would make GDAL (and the
    validator) read our easting-first coordinates swapped; the short form is read easting first."""
    for form in ("epsg:5186", "EPSG:5186", "urn:ogc:def:crs:EPSG::5186", "urn:ogc:def:crs:EPSG:9.8.15:5186",
                 "http://www.opengis.net/def/crs/EPSG/0/5186", "https://www.opengis.net/def/crs/EPSG/0/5186"):
        assert citygml.srs_name_of(form) == "EPSG:5186", form
    assert citygml.srs_name_of("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH") == "urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH"
    with pytest.raises(InputError, match="neither EPSG:<code> nor a CRS URI/URN"):
        citygml.srs_name_of("Korea 2000")


def test_raw_polygon_markup_is_what_lxml_would_write():
    """The ready-made markup for the repeated geometry (``_Writer.raw``) equals lxml's element."""
    geometry = ogr.CreateGeometryFromWkt("POLYGON Z ((0 0 1, 10 0 1, 10 10 2.5, 0 0 1), "
                                         "(2 1 1, 8 1 1, 8 7 1.25, 2 1 1))")
    gml = f"{{{citygml.NS['gml']}}}"
    expected = etree.Element(gml + "Polygon", {gml + "id": "BLD_1_f3"}, nsmap={"gml": citygml.NS["gml"]})
    for i, side in enumerate(("exterior", "interior")):
        ring = etree.SubElement(etree.SubElement(expected, gml + side), gml + "LinearRing",
                                {gml + "id": f"BLD_1_f3_r{i or ''}"})
        pos = etree.SubElement(ring, gml + "posList", {"srsDimension": "3"})
        pos.text = " ".join(f"{c:.3f}" for p in geometry.GetGeometryRef(i).GetPoints() for c in p)
    got = etree.fromstring(f'<r xmlns:gml="{citygml.NS["gml"]}">{citygml._polygon("BLD_1_f3", geometry)}</r>')[0]
    assert etree.tostring(got, method="c14n") == etree.tostring(expected, method="c14n")


def test_a_tin_triangle_id_must_be_an_integer():
    assert citygml_inputs.tri_ids(np.array([12, -3], dtype=np.int32)) == ["tri_12", "tri_-3"]
    assert citygml_inputs.tri_ids(np.array([b"12"])) == ["tri_12"]  # a text field holding integers
    for bad in (np.array([b"12", b'1"><x']), np.ma.masked_array([5, 6], mask=[False, True])):
        with pytest.raises(InputError, match="not an integer"):
            citygml_inputs.tri_ids(bad)


@pytest.mark.parametrize("surface", ["tri_7", "BLD_1_f3"])
def test_raw_texture_association_is_what_lxml_would_write(tmp_path, surface):
    """The ready-made markup of a road triangle's or a face's texture association equals what ``association``
    writes."""
    with open(tmp_path / "a.xml", "wb") as fh, etree.xmlfile(fh, encoding="utf-8") as xf:
        with xf.element("r", nsmap={"app": citygml.NS["app"]}):
            writer = citygml._Writer(xf, fh, citygml.WriteReport(), None)
            with writer.association(f"#{surface}"):
                writer.leaf(citygml.APP + "textureCoordinates", "0.5 0.25 1 0 0 1 0.5 0.25")
                writer.leaf(citygml.APP + "ring", f"#{surface}_r")
            writer.raw(citygml._ASSOCIATION.format(surface=surface, uv="0.5 0.25 1 0 0 1 0.5 0.25"))
    text = (tmp_path / "a.xml").read_text(encoding="utf-8")
    body = text[text.index(">", text.index("<r ")) + 1:text.rindex("</r>")]
    lxml_part, raw_part = body[:len(body) // 2], body[len(body) // 2:]
    assert lxml_part == raw_part and raw_part.startswith("\n<app:textureParameterization>")


def _uv_column(texts: list[str | None]) -> np.ma.MaskedArray:
    """A text column as GDAL's Arrow reader gives it: fixed-width UTF-8 bytes, NULL masked."""
    return np.ma.masked_array(np.array([(t or "").encode() for t in texts], dtype="S"), [t is None for t in texts])


def test_texture_coordinates_are_checked_and_normalised_a_batch_at_once():
    texts = ["0.1234567891 0.5 1.0 0 -0.0 1e-05 0.1234567891 0.5", "0.25 0.75 0.5 0.5 1 1 0.25 0.75"]
    expected = [" ".join(format(float(v), ".7g") for v in t.split()) for t in texts]
    tin = (["tin", "tin"], ["7", "8"], ["", ""])
    assert citygml._uv_texts(_uv_column(texts), *tin, "t.gpkg") == expected
    aligned = ["0.250000000000 0.750000000000 0.500000000000 0.500000000000 1.000000000000 1.000000000000 "
               "0.250000000000 0.750000000000"] * 2  # the texture step's "%.12f" (parsed column by column)
    assert citygml._uv_texts(_uv_column(aligned), *tin, "t.gpkg") == [expected[1]] * 2
    assert citygml._uv_texts(_uv_column(["0 0 1 0 1 1 0 1 0 0"]), ["roof"], ["BLD_1"], ["2"], "t.gpkg") == [
        "0 0 1 0 1 1 0 1 0 0"]
    irregular = [texts[0], "0.25\t0.75  0.5 0.5 1 1\n0.25 0.75 "]  # any spacing
    assert citygml._uv_texts(_uv_column(irregular), *tin, "t.gpkg") == expected
    assert citygml._uv_texts(np.array(irregular, dtype=object), *tin, "t.gpkg") == expected
    for bad, target, surface in (("0 0 1 0 1 1", "tin", "TIN triangle 8"), ("0 0 1 0 1 1 0 0 1", "road", "road tri_8"),
                                 ("0 0 1 0 1 1 0 0 nan 0", "wall", "wall 8_f3"), ("0 0 1 x 1 1 0 0", "tin", "TIN "),
                                 ("", "tin", "TIN "), (None, "roof", "roof 8_f3"),
                                 ("0 0 1 0 1 1 0 0 0 0", "tin", "TIN ")):
        with pytest.raises(InputError, match=f"Texture coordinates of {surface}.* in t.gpkg are not a valid list"):
            citygml._uv_texts(_uv_column([texts[1], bad]), ["tin", target], ["7", "8"], ["", "3"], "t.gpkg")
    with pytest.raises(InputError, match="t.gpkg has the unknown target 'door'"):  # the first row that is wrong
        citygml._uv_texts(_uv_column([texts[1], "0 0 1", texts[1]]), ["tin", "door", "tin"], ["7", "8", "9"],
                          ["", "", ""], "t.gpkg")
    with pytest.raises(InputError, match="TIN triangle 8 in t.gpkg are not"):
        citygml._uv_texts(_uv_column([texts[1], "0 0 1", texts[1]]), ["tin", "tin", "door"], ["7", "8", "9"],
                          ["", "", ""], "t.gpkg")


@pytest.mark.parametrize("text", ["", NASTY.replace("\x01", "").replace("\x1f", ""), "cr\r lf\n tab\t", "]]> 수서 😀"])
def test_ready_made_text_is_what_lxml_writes(text, tmp_path):
    """Attributes go out as ready-made markup: their text must be escaped exactly as lxml escapes element text."""
    path = tmp_path / "t.xml"
    with etree.xmlfile(str(path), encoding="utf-8") as xf, xf.element("v"):
        xf.write(text)
    assert path.read_text(encoding="utf-8") == f"<v>{citygml.xml_text(text)}</v>"
    assert etree.fromstring(f"<v>{citygml.xml_text(text)}</v>".encode()).text == (text or None)
