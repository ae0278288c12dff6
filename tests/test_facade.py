"""Generated facades: use classes from the national codes and names, storey modules, walls' texture coordinates."""
from __future__ import annotations

import hashlib
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from test_texture import X0, Y0, make_ortho

from wit_plugin.infra import step_layers
from wit_plugin.texture import TextureConfig, texture_model
from wit_plugin.texture.facade import modules, uses
from wit_plugin.texture.facade.walls import wall_texcoords

JUSO = ["BDTYP_CD", "GRO_FLO_CO", "UND_FLO_CO"]
NGII = ["명칭", "구분", "종류", "용도", "주기", "층수", "UFID"]
AL_D010 = ["A0", "A1", "A8", "A9", "A16", "A26"]


def _facade(fields: list[str], attributes: dict, height: float = 9.0, storeys: int | None = 3) -> uses.Facade:
    rule = uses.UseRule.for_fields(fields)
    return rule.facade("BLD_1", attributes, height, storeys, "GRO_FLO_CO")


@pytest.mark.parametrize(("code", "storeys", "style"), [
    ("01001", 2, uses.HOUSE), ("01003", 3, uses.VILLA), ("02001", 15, uses.APARTMENT), ("02003", 4, uses.VILLA),
    ("03001", 2, uses.RETAIL), ("04001", 5, uses.RETAIL), ("14201", 8, uses.OFFICE), ("14201", 20, uses.CURTAIN_WALL),
    ("10101", 4, uses.PUBLIC), ("17100", 1, uses.INDUSTRIAL), ("18001", 1, uses.INDUSTRIAL),
    ("02000", 3, uses.VILLA), ("02000", 12, uses.APARTMENT),  # 공동주택 of no stated kind: by storeys
    ("26000", 1, uses.OTHER),  # 묘지관련시설: a use without a drawing of its own
    ("99999", 2, uses.HOUSE),  # not a use code: by storeys
])
def test_road_name_address_use_codes(code, storeys, style):
    facade = _facade(JUSO, {"BDTYP_CD": code}, height=3.0 * storeys, storeys=storeys)
    assert facade.style == style and facade.storeys == storeys and facade.storeys_source == "GRO_FLO_CO"
    assert facade.rule.startswith("BDTYP_CD " + code) == (code != "99999")


def test_a_use_code_read_as_a_number_keeps_its_leading_zero():
    assert _facade(JUSO, {"BDTYP_CD": 2001}).style == uses.APARTMENT
    assert _facade(JUSO, {"BDTYP_CD": 2001}).rule == "BDTYP_CD 02001"


@pytest.mark.parametrize(("kind", "use", "storeys", "style"), [
    ("일반주택", "단독주택", 1, uses.HOUSE), ("아파트", "공동주택", 20, uses.APARTMENT),
    ("연립주택", "공동주택", 3, uses.VILLA), ("주택외건물", "제1종근린생활시설", 3, uses.RETAIL),
    ("주택외건물", "업무시설", 6, uses.OFFICE), ("주택외건물", "교육연구시설", 4, uses.PUBLIC),
    ("주택외건물", "공장", 1, uses.INDUSTRIAL), (None, "공동주택", 3, uses.VILLA),
    (None, "공동주택", 7, uses.APARTMENT),
])
def test_ngii_kinds_and_uses_as_ngii_writes_them(kind, use, storeys, style):
    facade = _facade(NGII, {"종류": kind, "용도": use, "층수": storeys}, storeys=storeys)
    assert facade.style == style


def test_building_integrated_information_code_then_name():
    assert _facade(AL_D010, {"A8": "02001", "A9": "아파트"}, storeys=15).rule == "A8 02001"
    assert _facade(AL_D010, {"A8": None, "A9": "판매시설"}).style == uses.RETAIL
    assert uses.UseRule.for_fields(["A8", "A9"]).fields == []  # A8/A9 alone are no AL_D010 layer


@pytest.mark.parametrize(("tag", "style"), [("apartments", uses.APARTMENT), ("house", uses.HOUSE),
                                            ("retail", uses.RETAIL), ("office", uses.OFFICE),
                                            ("school", uses.PUBLIC), ("warehouse", uses.INDUSTRIAL),
                                            ("yes", uses.VILLA)])
def test_openstreetmap_building_tags(tag, style):
    assert _facade(["building", "building:levels"], {"building": tag}, storeys=3).style == style


def test_without_use_or_storeys_the_height_decides_at_the_style_storey_height():
    facade = _facade(["name"], {}, height=28.0, storeys=None)
    assert facade.style == uses.APARTMENT and facade.rule == "10 storeys (no use field)"
    assert facade.storeys == 10 and facade.storeys_source == "height ÷ 2.8 m"  # 28 m at the apartments' 2.8 m
    factory = _facade(JUSO, {"BDTYP_CD": "17100"}, height=12.0, storeys=None)
    assert factory.storeys == 2 and factory.storeys_source == "height ÷ 6 m"


def test_a_building_without_a_height_still_gets_a_facade():
    assert _facade(JUSO, {"BDTYP_CD": "02001"}, height=float("nan"), storeys=None).storeys == 1
    assert _facade(JUSO, {"BDTYP_CD": "02001"}, height=float("nan"), storeys=9).storeys == 9


def test_variant_and_phase_are_seeded_by_the_id():
    rule = uses.UseRule.for_fields(JUSO)
    first = [rule.facade(f"BLD_{k}", {"BDTYP_CD": "02001"}, 45.0, 15, "GRO_FLO_CO") for k in range(200)]
    again = [rule.facade(f"BLD_{k}", {"BDTYP_CD": "02001"}, 45.0, 15, "GRO_FLO_CO") for k in range(200)]
    assert first == again
    assert {f.variant for f in first} == set(range(uses.VARIANTS))
    assert len({f.phase for f in first}) > 50 and all(0.0 <= f.phase < 1.0 for f in first)


def test_modules_are_deterministic_tileable_and_stack_one_row_per_storey():
    digests = {}
    for style in uses.STYLES:
        for variant in range(uses.VARIANTS):
            image = modules.facade_image(style, variant, 8)
            assert image.shape == (8 * modules.STOREY_PX, modules.MODULE_PX, 3) and image.dtype == np.uint8
            upper, ground = modules.storey_modules(style, variant)
            assert (image[-modules.STOREY_PX:] == ground).all()  # the ground floor at the bottom
            assert all((image[k * modules.STOREY_PX:(k + 1) * modules.STOREY_PX] == upper).all() for k in range(7))
            # tileable: the wrap (last column → first) makes no edge the module does not have inside (5 %: grain)
            for module in (upper, ground):
                columns = module.astype(int)
                inside = np.abs(np.diff(columns, axis=1)).sum(axis=(0, 2))
                seam = np.abs(columns[:, 0] - columns[:, -1]).sum()
                assert seam <= 1.05 * inside.max(), (style, variant)
            digests[style, variant] = hashlib.sha256(image.tobytes()).hexdigest()
    assert len(set(digests.values())) == len(digests)  # every variant looks different
    assert digests == {key: hashlib.sha256(modules.facade_image(*key, 8).tobytes()).hexdigest() for key in digests}
    shop_upper, shop_ground = modules.storey_modules(uses.RETAIL, 0)
    assert (shop_upper != shop_ground).any()  # a shop front
    house_upper, house_ground = modules.storey_modules(uses.HOUSE, 0)
    assert (house_upper == house_ground).all()


def test_wall_texcoords_run_on_around_each_ring_and_close_on_whole_modules():
    # a 12.8 m × 6.4 m block (2 + 1 + 2 + 1 modules), then a courtyard ring of 4 × 3.2 m (2 modules)
    outer = [(0, 0), (12.8, 0), (12.8, 6.4), (0, 6.4)]
    inner = [(4, 2), (4, 5.2), (7.2, 5.2), (7.2, 2)]
    edges = [(a, b) for ring in (outer, inner) for a, b in zip(ring, ring[1:] + ring[:1])]
    base = np.array(edges, dtype=float)
    first = np.array([True] + [False] * 7)
    uv = wall_texcoords(base, first, np.full(8, 0.25), np.full(8, 6 / 8)).reshape(8, 5, 2)
    u0, u1 = uv[:, 0, 0], uv[:, 1, 0]
    assert u0 == pytest.approx([0.25, 2.25, 3.25, 5.25, 0.25, 0.75, 1.25, 1.75])
    assert u1 == pytest.approx([2.25, 3.25, 5.25, 6.25, 0.75, 1.25, 1.75, 2.25])
    assert (uv[:, [0, 1, 4], 1] == 0).all() and (uv[:, [2, 3], 1] == 0.75).all()
    assert (uv[:, 2, 0] == u1).all() and (uv[:, 3, 0] == u0).all() and (uv[:, 4] == uv[:, 0]).all()
    # a ring that is no whole number of modules is stretched to the nearest: 13 m holds 2 modules of 6.5 m
    odd = wall_texcoords(np.array([[(0, 0), (13, 0)], [(13, 0), (0, 0)]]), np.array([True, False]),
                         np.zeros(2), np.ones(2)).reshape(2, 5, 2)
    assert odd[:, 1, 0] == pytest.approx([2.0, 4.0])


def _lod1_with_uses(path: Path) -> str:
    """Two buildings as wit:extrudebuildings writes them (with a use code and floors), one with a courtyard."""
    from osgeo import ogr, osr

    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(step_layers.LOD1_LAYER, srs, ogr.wkbPolygon25D)
    for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                       (step_layers.FACE_NUMBER, ogr.OFTInteger), (step_layers.HEIGHT, ogr.OFTReal),
                       (step_layers.STOREYS_ABOVE, ogr.OFTInteger), ("BDTYP_CD", ogr.OFTString),
                       ("GRO_FLO_CO", ogr.OFTInteger)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    import shapely

    from wit_plugin.buildings.extrude import solid_faces
    x, y = X0 + 10, Y0 - 50
    buildings = [("BLD_APT", shapely.box(x, y, x + 30, y + 12), 15, "02001"),
                 ("BLD_SHOP", shapely.box(x + 40, y, x + 60, y + 20).difference(
                     shapely.box(x + 46, y + 6, x + 54, y + 14)), 3, "03001")]
    for wit_id, footprint, floors, code in buildings:
        for number, (kind, rings) in enumerate(solid_faces(footprint, 10.0, floors * 3.0)):
            feature = ogr.Feature(layer.GetLayerDefn())
            for name, value in ((step_layers.WIT_ID, wit_id), (step_layers.FACE_TYPE, kind),
                                (step_layers.FACE_NUMBER, number), (step_layers.HEIGHT, floors * 3.0),
                                (step_layers.STOREYS_ABOVE, floors), ("BDTYP_CD", code), ("GRO_FLO_CO", floors)):
                feature.SetField(name, value)
            feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.Polygon(rings[0], rings[1:]).wkb))
            layer.CreateFeature(feature)
    ds = None
    return str(path)


def test_texture_step_writes_one_row_per_storey_and_no_corner_jump(tmp_path):
    """The texture table read back: every wall's v spans its building's storeys in whole image rows, u runs on
    from wall to wall and each ring closes on a whole number of modules; the facade table says what was made."""

    ortho = make_ortho(tmp_path / "ortho.tif", size=(200, 200))
    lod1 = _lod1_with_uses(tmp_path / "lod1.gpkg")
    out = tmp_path / "tex"
    report = texture_model(ortho, lod1, None, str(out))
    assert report.surfaces["wall"] == 4 + 8 and report.untextured["wall"] == 0
    assert report.facades == {"apartment": 1, "retail": 1} and report.facade_images == 2
    with sqlite3.connect(out / step_layers.FACADE_FILE) as db:
        facades = {row[0]: row[1:] for row in db.execute(
            f"SELECT {', '.join(step_layers.FACADE_FIELDS)} FROM {step_layers.FACADE_TABLE}")}
    apt_image = facades["BLD_APT"][-1]
    assert facades["BLD_APT"][:5] == ("generated", "apartment", "BDTYP_CD 02001", 15, "GRO_FLO_CO")
    assert apt_image.startswith("facade_apartment_") and apt_image.endswith(".png")
    with sqlite3.connect(out / step_layers.TEXCOORD_FILE) as db:
        rows = db.execute(f"SELECT feature, face_no, image, uv FROM {step_layers.TEXCOORD_TABLE} "
                          "WHERE target = 'wall' ORDER BY feature, face_no").fetchall()
    from osgeo import gdal
    image_rows = {}
    for wit_id in ("BLD_APT", "BLD_SHOP"):
        walls = [(face, image, np.array(uv.split(), dtype=float).reshape(5, 2)) for f, face, image, uv in rows
                 if f == wit_id]
        image_rows[wit_id] = gdal.Open(str(out / walls[0][1])).RasterYSize // modules.STOREY_PX
        storeys = facades[wit_id][3]
        for _, image, uv in walls:
            assert image == facades[wit_id][-1]
            assert uv[[0, 1, 4], 1].tolist() == [0, 0, 0] and uv[2, 1] * image_rows[wit_id] == pytest.approx(storeys)
        rings = [walls[:4], walls[4:]]  # the shop's courtyard: a second ring
        for ring in filter(None, rings):
            for (_, _, a), (_, _, b) in zip(ring, ring[1:]):
                assert b[0, 0] == pytest.approx(a[1, 0])  # no jump at the corner
            span = ring[-1][2][1, 0] - ring[0][2][0, 0]
            assert span == pytest.approx(round(span)) and span >= 1  # whole modules around the ring
    assert image_rows == {"BLD_APT": 16, "BLD_SHOP": 4}  # 15 and 3 storeys: the next powers of two


def test_no_facades_when_asked(tmp_path):

    ortho = make_ortho(tmp_path / "ortho.tif", size=(200, 200))
    lod1 = _lod1_with_uses(tmp_path / "lod1.gpkg")
    report = texture_model(ortho, lod1, None, str(tmp_path / "tex"), TextureConfig(facades="none"))
    assert report.surfaces["wall"] == 0 and report.untextured["wall"] == 12 and report.facades == {}
    assert not (tmp_path / "tex" / step_layers.FACADE_FILE).exists()
    assert not any(p.name.startswith("facade_") for p in (tmp_path / "tex").iterdir())


def test_texture_measures_leave_the_generated_facades_out(tmp_path):
    """Sharpness and contrast (paper Table 19) are of the textures cut from the orthoimage: the drawn facades,
    with their sharp edges, do not change them."""
    from wit_plugin.metrics.texture import texture_metrics

    rng = np.random.default_rng(3)
    ortho = make_ortho(tmp_path / "ortho.tif", pixels=rng.integers(0, 255, (200, 200, 3), dtype=np.uint8))
    lod1 = _lod1_with_uses(tmp_path / "lod1.gpkg")
    texture_model(ortho, lod1, None, str(tmp_path / "with"))
    texture_model(ortho, lod1, None, str(tmp_path / "without"), TextureConfig(facades="none"))
    assert any(p.name.startswith("facade_") for p in (tmp_path / "with").iterdir())
    measured = [texture_metrics(str(tmp_path / name)) for name in ("with", "without")]
    assert [m.images for m in measured[0:1]] == [m.images for m in measured[1:2]]
    assert measured[0].laplacian_variance == measured[1].laplacian_variance > 0
    assert measured[0].contrast == measured[1].contrast > 0
