"""The chain in the core (wit_plugin.chain, no QGIS): any building layer's heights, coverage checked
before the heavy steps (naming the missing sheets), surfaces outside the ortho left untextured on
request, and nothing left behind when a run fails."""
from __future__ import annotations

import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import shapely
from lxml import etree
from osgeo import gdal, ogr, osr

from wit_plugin.buildings.heights import HeightOptions
from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
from wit_plugin.chain.citymodel import _Clock
from wit_plugin.chain.programs import BESIDE_NICENESS
from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import CanceledError, InputError, MissingDependencyError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.infra.io.vector_io import read_layer
from wit_plugin.prepare.area import StudyArea
from wit_plugin.sample import SampleConfig, generate_sample

NS = {"bldg": "http://www.opengis.net/citygml/building/3.0", "core": "http://www.opengis.net/citygml/3.0",
      "gen": "http://www.opengis.net/citygml/generics/3.0", "con": "http://www.opengis.net/citygml/construction/3.0",
      "gml": "http://www.opengis.net/gml/3.2"}
SUSEO = (127.1020, 37.4876)


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    """A small sample around Suseo; its study area straddles sheets 37709004 (west) and 37709005."""
    return generate_sample(tmp_path_factory.mktemp("sample"), SampleConfig(radius_m=300.0, seed=5,
                                                                             ortho_pixel_size=1.0))


def _options(**kwargs) -> ChainOptions:
    base = dict(area=StudyArea.circle(*SUSEO, 220.0), max_edge=15.0, metrics=False)
    base.update(kwargs)
    return ChainOptions(**base)


def _inputs(sample, **kwargs) -> ChainInputs:
    base = dict(ortho=[str(sample.ortho_tiles[0].parent)], dem=str(sample.dem), buildings=str(sample.buildings),
                roads=str(sample.roads), districts=str(sample.districts))
    base.update(kwargs)
    return ChainInputs(**base)


def _osm_layer(sample, path: Path) -> tuple[Path, dict[str, tuple]]:
    """The sample's footprints as an OpenStreetMap export: ``height`` (text with units, sometimes),
    ``building:levels``, ``name`` — no GRO_FLO_CO. Returns the layer and osm_id → (height, levels)."""
    src = read_layer(sample.buildings, encoding="CP949")
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    srs = osr.SpatialReference()
    srs.ImportFromWkt(src.crs.to_wkt())
    layer = ds.CreateLayer("buildings", srs, ogr.wkbPolygon)
    for name, kind in (("osm_id", ogr.OFTString), ("building", ogr.OFTString), ("height", ogr.OFTString),
                       ("building:levels", ogr.OFTString), ("name", ogr.OFTString)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    rows = {}
    for k, geom in enumerate(src.geoms):
        if geom is None:
            continue
        osm_id = f"way/{1000 + k}"
        height = ("", f"{10 + k % 7}.5", f"{20 + k % 5} m", "")[k % 4]
        levels = ("4", "", "", "")[k % 4] if k % 8 else ""  # every 8th has neither: default height
        rows[osm_id] = (height, levels)
        feature = ogr.Feature(layer.GetLayerDefn())
        for field, value in (("osm_id", osm_id), ("building", "yes"), ("height", height),
                             ("building:levels", levels), ("name", f"건물 {k}")):
            if value:
                feature.SetField(field, value)
        feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(geom)))
        layer.CreateFeature(feature)
    ds = None
    return path, rows


def test_openstreetmap_heights_flow_into_the_citygml(sample, tmp_path):
    osm, rows = _osm_layer(sample, tmp_path / "osm.gpkg")
    report = run_city_model(_inputs(sample, buildings=str(osm), roads=None, districts=None), _options(),
                            tmp_path / "city")
    assert report.valid and report.errors == 0
    doc = etree.parse(report.gml)
    buildings = doc.findall(".//bldg:Building", NS)
    assert len(buildings) == report.buildings > 20

    def generic(building, name):
        values = building.xpath(f"core:genericAttribute/*[gen:name='{name}']/gen:value/text()", namespaces=NS)
        return values[0] if values else None

    expected_default = 0
    for building in buildings:
        osm_id = generic(building, "osm_id")
        height_text, levels = rows[osm_id]
        height = float(building.find("con:height/con:Height/con:value", NS).text)
        if height_text:
            assert height == pytest.approx(float(height_text.split()[0]), abs=5e-4)
            assert generic(building, step_layers.HEIGHT_RULE) == "height (m)"
            assert generic(building, "height") == height_text  # the source attribute, not shadowed
            assert building.find("con:height/con:Height/con:status", NS).text == "measured"
        elif levels:
            assert height == pytest.approx(3.0 * int(levels))
            assert generic(building, step_layers.HEIGHT_SOURCE) == "floors"
            assert building.find("bldg:storeysAboveGround", NS).text == levels
        else:
            expected_default += 1
            assert generic(building, step_layers.HEIGHT_SOURCE) == "default" and height == 3.0
    assert report.default_heights == expected_default > 0


def test_an_explicit_height_field_and_expression(sample, tmp_path):
    osm, rows = _osm_layer(sample, tmp_path / "osm.gpkg")
    heights = HeightOptions(expression_text="(levels) * 4", expression=lambda a: float(a["building:levels"]) * 4
                            if a.get("building:levels") else None, default_height=7.0)
    report = run_city_model(_inputs(sample, buildings=str(osm), roads=None, districts=None),
                            _options(heights=heights), tmp_path / "city")
    doc = etree.parse(report.gml)
    values = {float(v) for v in doc.xpath("//con:height/con:Height/con:value/text()", namespaces=NS)}
    assert values == {16.0, 7.0}  # the expression replaces the recognised height field; the rest default


def test_missing_sheet_is_named_before_any_heavy_step_and_nothing_is_written(sample, tmp_path, monkeypatch):
    """The coverage check names the missing sheet before georeferencing or meshing anything."""
    from wit_plugin.chain import citymodel

    def heavy(*args, **kwargs):
        raise AssertionError("a heavy step ran before the coverage check")

    monkeypatch.setattr(citymodel, "georeference_sheets", heavy)
    monkeypatch.setattr(citymodel, "triangulate_terrain", heavy)
    ortho = tmp_path / "ortho"
    ortho.mkdir()
    for tile in sample.ortho_tiles:
        if "37709004" not in tile.name:
            shutil.copy(tile, ortho / tile.name)
    out = tmp_path / "city"
    with pytest.raises(InputError, match=r"uncovered .*the sheets that would cover it: 37709004\. Add those TIFs"):
        run_city_model(_inputs(sample, ortho=[str(ortho)]), _options(area=StudyArea.circle(*SUSEO, 290.0)), out)
    assert list(out.iterdir()) == []


def test_outside_the_ortho_left_untextured_on_request(sample, tmp_path):
    ortho = tmp_path / "ortho"
    ortho.mkdir()
    kept = [t for t in sample.ortho_tiles if "37709004" not in t.name]
    for tile in kept:
        shutil.copy(tile, ortho / tile.name)
    report = run_city_model(_inputs(sample, ortho=[str(ortho)]),
                            _options(area=StudyArea.circle(*SUSEO, 290.0), outside_ortho="untextured"),
                            tmp_path / "city")
    assert report.valid and report.untextured_outside > 0
    assert sorted(p.name for p in Path(report.output).iterdir()) == [
        "3dtiles", "lod1.gpkg", "model.gml", "model_textures", "steps.json", "tin.gpkg", "validation.html"]


def test_dem_that_stops_short_is_named(sample, tmp_path):
    short = tmp_path / "dem_short.tif"
    ds = gdal.Open(str(sample.dem))
    gt = ds.GetGeoTransform()
    gdal.Translate(str(short), ds, srcWin=[0, 0, ds.RasterXSize // 2, ds.RasterYSize])  # the western half
    east = gt[0] + gt[1] * (ds.RasterXSize // 2)
    with pytest.raises(InputError, match=r"does not cover the area .* stops short by [\d,.]+ m to the east"):
        run_city_model(_inputs(sample, dem=str(short)), _options(), tmp_path / "city")
    assert east < 209020.9 + 220  # (the cut really is inside the area)
    assert list((tmp_path / "city").iterdir()) == []


def test_district_by_name_and_the_whole_chain_result(sample, tmp_path):
    districts = read_layer(sample.districts, encoding="CP949")
    names = [n for n in districts.columns["EMD_KOR_NM"]]
    suseo = names[int(np.argmax([g.area for g in districts.geoms]))]
    report = run_city_model(_inputs(sample), _options(area=StudyArea.from_district_code(suseo), metrics=True),
                            tmp_path / "city")
    assert report.valid and report.buildings > 0 and report.metrics
    assert list(report.seconds) == ["prepare", "coverage", "georeference", "merge", "extrude", "terrain", "metrics",
                                    "texture", "3dtiles", "citygml", "validate"]


def test_the_chain_writes_the_3d_tiles_web_profile_on_request(sample, tmp_path):
    import pygltflib

    report = run_city_model(_inputs(sample), _options(area=StudyArea.circle(*SUSEO, 150.0), tiles3d_web=True),
                            tmp_path / "city")
    tiles = sorted((Path(report.output) / "3dtiles").rglob("*.glb"))
    assert report.valid and tiles
    for path in tiles:
        gltf = pygltflib.GLTF2().load_binary(str(path))
        assert {"EXT_meshopt_compression", "KHR_mesh_quantization"} <= set(gltf.extensionsRequired), path


def test_the_web_profile_without_meshoptimizer_stops_before_anything_is_written(sample, tmp_path, monkeypatch):
    from wit_plugin.infra.errors import MissingDependencyError

    monkeypatch.setitem(sys.modules, "meshoptimizer", None)  # as if it were not installed
    with pytest.raises(MissingDependencyError, match=r'pip install .*"meshoptimizer==0.2.30a0"'):
        run_city_model(_inputs(sample), _options(tiles3d_web=True), tmp_path / "city")
    assert not (tmp_path / "city").exists() or not any((tmp_path / "city").iterdir())


def test_every_wall_of_the_sample_has_its_facade_one_image_row_per_storey_and_no_corner_jump(sample, tmp_path):
    """The CityGML read back: every wall of every building is in the generatedFacade theme (its own appearance,
    described as generated, wrapping), with one texture row per storey of its building (the image's rows are
    storeys: the roof line on a row boundary) and u running on from wall to wall around each ring, closing on a
    whole number of modules; each building says how its facade was made."""
    report = run_city_model(_inputs(sample), _options(tiles3d=False), tmp_path / "city")
    assert report.valid and report.errors == 0
    doc = etree.parse(report.gml)
    app = "http://www.opengis.net/citygml/appearance/3.0"
    ns = {**NS, "app": app}
    walls, storeys = {}, {}
    for building in doc.iterfind(".//bldg:Building", ns):
        wit_id = building.get(f"{{{ns['gml']}}}id")
        generic = {n: v for n, v in zip(building.xpath("core:genericAttribute/*/gen:name/text()", namespaces=ns),
                                        building.xpath("core:genericAttribute/*/gen:value/text()", namespaces=ns))}
        assert generic[step_layers.FACADE] == "generated" and generic[step_layers.FACADE_STYLE]
        storeys[wit_id] = int(generic[step_layers.FACADE_STOREYS])
        above = building.find("bldg:storeysAboveGround", ns)
        assert above is None or int(above.text) == storeys[wit_id]  # the layer's floor count when it has one
        for polygon in building.iterfind(".//gml:Polygon", ns):
            points = np.array(polygon.find(".//gml:posList", ns).text.split(), dtype=float).reshape(-1, 3)
            if len(points) == 5 and points[0, 2] != points[2, 2]:  # a wall: base edge, then up
                walls[polygon.get(f"{{{ns['gml']}}}id")] = (wit_id, points)
    assert len(storeys) == report.buildings > 20
    facades = [a for a in doc.iterfind(".//app:Appearance", ns) if a.findtext("app:theme", namespaces=ns)
               == "generatedFacade"]
    assert facades and all("Generated facade" in a.findtext("gml:description", namespaces=ns) for a in facades)
    found = {}
    for appearance in facades:
        texture = appearance.find(".//app:ParameterizedTexture", ns)
        assert texture.findtext("app:wrapMode", namespaces=ns) == "wrap"
        image = Path(report.gml).parent / texture.findtext("app:imageURI", namespaces=ns)
        rows = gdal.Open(str(image)).RasterYSize // 32
        for association in texture.iterfind(".//app:TextureAssociation", ns):
            target = association.findtext("app:target", namespaces=ns)[1:]
            uv = np.array(association.findtext(".//app:textureCoordinates", namespaces=ns).split(),
                          dtype=float).reshape(-1, 2)
            found[target] = (uv, rows)
    assert set(found) == set(walls)  # every wall, and walls only
    by_building = {}
    for face, (wit_id, points) in walls.items():
        by_building.setdefault(wit_id, []).append((int(face.rsplit("_f", 1)[1]), points, *found[face]))
    for wit_id, faces in by_building.items():
        faces.sort(key=lambda f: f[0])
        ring_start = None
        for k, (_, points, uv, rows) in enumerate(faces):
            assert uv[[0, 1, 4], 1].tolist() == [0.0, 0.0, 0.0]
            assert uv[2, 1] * rows == pytest.approx(storeys[wit_id], abs=1e-5), wit_id  # a row per storey
            if ring_start is None:
                ring_start = uv[0, 0]
            following = faces[k + 1] if k + 1 < len(faces) else None
            if following is not None and np.allclose(following[1][0], points[1], atol=1e-6):
                assert following[2][0, 0] == pytest.approx(uv[1, 0], abs=1e-5)  # no jump at the corner
            else:  # the ring closes: a whole number of modules around it
                turns = uv[1, 0] - ring_start
                assert turns == pytest.approx(round(turns), abs=1e-4) and round(turns) >= 1
                ring_start = None


class _Log(Feedback):
    def __init__(self, cancel_after: float | None = None):
        self.infos, self.warnings, self.cancel_at = [], [], cancel_after and time.perf_counter() + cancel_after

    def info(self, message: str) -> None:
        self.infos.append(message)

    def warning(self, message: str) -> None:
        self.warnings.append(message)

    def is_canceled(self) -> bool:
        return bool(self.cancel_at) and time.perf_counter() > self.cancel_at


def _child(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def test_a_step_beside_passes_its_messages_on_and_is_timed_by_its_own_end():
    """A step in a second process (merge, 3dtiles, metrics): its information stays information, its warnings
    warnings, each labelled; 200 kB on stderr (more than a pipe holds) does not stall it while the block runs;
    its time is its own (0.3 s), not the 2 s the block took before waiting for it."""
    log = _Log()
    clock = _Clock(log)
    code = ("import sys, time\nfrom wit_plugin.infra.step_process import RecordFeedback\n"
            "f = RecordFeedback()\nf.info('read 3 sheets')\nf.warning('sheet 4 is empty\\nsheet 5 too')\n"
            "f.progress(50.0)\nsys.stderr.write('x' * 200_000 + '\\n')\ntime.sleep(0.3)\n")
    with clock.beside("merge", _child(code)) as merging:
        time.sleep(2.0)
        merging.wait()
    assert "merge: read 3 sheets" in log.infos
    assert log.warnings[0] == "merge: sheet 4 is empty\nsheet 5 too"  # (a message of two lines stays one)
    assert log.warnings[1] == "merge: " + "x" * 200_000  # (a line not a record: a library's, say)
    assert 0.3 <= clock.seconds["merge"] < 1.5


def test_a_step_beside_that_fails_or_is_cancelled_stops_the_run():
    clock = _Clock(_Log())
    refusal = ("import sys\nfrom wit_plugin.infra.errors import MissingDependencyError\n"
               "from wit_plugin.infra.step_process import run_step\n"
               "def step(feedback):\n    raise MissingDependencyError('pygltflib is not installed')\n"
               "sys.exit(run_step(step))\n")
    with pytest.raises(MissingDependencyError, match=r"^The 3dtiles step failed: pygltflib is not installed$"):
        with clock.beside("3dtiles", _child(refusal)) as exporting:  # (its kind kept, as the chain apart's)
            exporting.wait()
    with pytest.raises(InputError, match=r"^The metrics step failed: .*ValueError: no footprints"):
        with clock.beside("metrics", _child("raise ValueError('no footprints')")) as measuring:
            measuring.tell()  # (it ended already: telling it is no error, waiting says how it ended)
            measuring.wait()
    clock = _Clock(_Log(cancel_after=0.5))
    started = time.perf_counter()
    with pytest.raises(CanceledError):
        with clock.beside("3dtiles", _child("import time; time.sleep(60)")) as exporting:
            exporting.wait()
    assert time.perf_counter() - started < 5


def test_a_step_beside_waits_until_told_and_is_stopped_with_the_block(tmp_path):
    """The metrics start beside the texture step and read the images once told (a line on their standard input);
    a block that fails stops a step that still waits (it is never told, never left running). Every step beside
    runs at a lower priority than the chain (the chain's steps are the path the others wait for)."""
    log = _Log()
    clock = _Clock(log)
    code = ("import os, sys, time\nfrom wit_plugin.infra.step_process import RecordFeedback\n"
            "f = RecordFeedback()\nstarted = time.perf_counter()\nline = sys.stdin.readline()\n"
            "f.info(f'told {line.strip()!r} after {time.perf_counter() - started:.1f} s')\n"
            "f.info(f'niceness {os.getpriority(os.PRIO_PROCESS, 0)}')\n")
    with clock.beside("metrics", _child(code)) as measuring:
        time.sleep(1.0)
        measuring.tell()
        measuring.wait()
    told = [m for m in log.infos if m.startswith("metrics: told")]
    assert told and told[0].startswith("metrics: told 'go' after ") and float(told[0].split()[-2]) >= 0.9
    ours = os.getpriority(os.PRIO_PROCESS, 0)
    assert f"metrics: niceness {min(ours + BESIDE_NICENESS, 19)}" in log.infos
    niceness = ("import os\nfrom wit_plugin.infra.step_process import RecordFeedback\n"
                "RecordFeedback().info(f'merging at niceness {os.getpriority(os.PRIO_PROCESS, 0)}')\n")
    with clock.beside("merge", _child(niceness)) as merging:  # (the texture step waits for it: the terrain is the
        merging.wait()  # path while it runs, and once the chain waits, idle, it gets the CPU all the same)
    assert f"merge: merging at niceness {min(ours + BESIDE_NICENESS, 19)}" in log.infos
    waiting = _child("import pathlib, sys\nsys.stdin.readline()\npathlib.Path(sys.argv[1]).write_text('read')")
    marker = tmp_path / "read.txt"
    started = time.perf_counter()
    with pytest.raises(RuntimeError, match="texture step failed"):
        with clock.beside("metrics", [*waiting, str(marker)]):
            raise RuntimeError("texture step failed")
    time.sleep(0.5)
    assert time.perf_counter() - started < 5 and not marker.exists()  # killed, not told
