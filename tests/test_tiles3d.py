"""wit:export3dtiles on a small generated sample: glTF validity (Khronos validator), tileset structure,
coordinates back to the model's within 1 cm, building metadata, and the offline viewer in a real
browser (headless Chromium from Debian, driven by playwright-core: loads, shows the model, a click
shows a building's attributes with its Korean name)."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pygltflib
import pytest
import shapely
from osgeo import gdal, ogr

from conftest import ensure_wit_provider, view_in_chromium
from wit_plugin import model
from wit_plugin.errors import CanceledError, InputError
from wit_plugin.feedback import Feedback
from wit_plugin.sample import SampleConfig, generate_sample
from wit_plugin.tiles3d import TilesetConfig, export_tileset
from wit_plugin.tiles3d.geo import Georeference, gltf_to_model

ROOT = Path(__file__).resolve().parents[1]
VIEWER = ROOT / "viewer"
CRS = "EPSG:5186"


@pytest.fixture(scope="module")
def chain(tmp_path_factory, qgis_processing):
    """The steps up to the textures on a 200 m sample, then the tileset through Processing (128 m leaves:
    three levels, so upper tiles are tested too)."""
    import processing

    ensure_wit_provider()
    out = tmp_path_factory.mktemp("tiles3d")
    sample = generate_sample(out / "sample", SampleConfig(radius_m=200.0, seed=7, ortho_pixel_size=1.0))
    run = processing.run
    geo = run("wit:georeferencemapsheets", {"INPUT": [str(sample.ortho_tiles[0].parent)], "OUTPUT": str(out / "geo"),
                                            "OUTPUT_INDEX": str(out / "sheets.gpkg")})
    mosaic = run("wit:mergetiles", {"INPUT": geo["OUTPUT_LAYERS"], "OVERLAP": 1, "OUTPUT": str(out / "mosaic.tif")})
    prepared = run("wit:preparevectors", {"BUILDINGS": str(sample.buildings), "ROADS": str(sample.roads),
                                          "DISTRICTS": str(sample.districts), "RADIUS": 200.0,
                                          "OUTPUT": str(out / "prepared.gpkg")})
    tin = run("wit:triangulateterrain", {"DEM": str(sample.dem), "AREA": f"{prepared['OUTPUT']}|layername=study_area",
                                         "BUILDINGS": prepared["BUILDINGS_OUT"], "ROADS": prepared["ROADS_OUT"],
                                         "MAX_EDGE": 10.0, "OUTPUT": str(out / "tin.gpkg")})
    lod1 = run("wit:extrudebuildings", {"BUILDINGS": prepared["BUILDINGS_OUT"], "DEM": str(sample.dem),
                                        "SPATIAL_INDEX": False, "OUTPUT": str(out / "lod1.gpkg")})
    texture = run("wit:wittexture", {"ORTHO": mosaic["OUTPUT"], "LOD1": lod1["LOD1"], "TIN": tin["TIN"],
                                     "OUTPUT": str(out / "textures")})
    tiles = run("wit:export3dtiles", {"LOD1": lod1["LOD1"], "TIN": tin["TIN"], "TEXTURES": texture["OUTPUT"],
                                      "LEAF_SIZE": 128.0, "OUTPUT": str(out / "3dtiles")})
    return {"out": out, "lod1": lod1["LOD1"].split("|")[0], "tin": tin["TIN"].split("|")[0],
            "textures": texture["OUTPUT"], "tiles": tiles,
            "folder": Path(tiles["OUTPUT"]), "buildings": lod1["SOLIDS"], "triangles": tin["TRIANGLES"]}


def _tiles(tile: dict, world: np.ndarray, parent: dict | None = None):
    """(tile, world matrix, parent) for every tile, depth first."""
    matrix = world @ np.array(tile.get("transform", np.eye(4).ravel()), dtype=float).reshape(4, 4).T
    yield tile, matrix, parent
    for child in tile.get("children", []):
        yield from _tiles(child, matrix, tile)


def _positions(path: Path) -> dict[str, np.ndarray]:
    """POSITION and _FEATURE_ID_0 (or -1) of every primitive of a .glb, and the materials' image URIs."""
    gltf = pygltflib.GLTF2().load_binary(str(path))
    blob = gltf.binary_blob()

    def read(index: int, width: int) -> np.ndarray:
        accessor = gltf.accessors[index]
        view = gltf.bufferViews[accessor.bufferView]
        dtype = {5126: np.float32, 5125: np.uint32, 5123: np.uint16}[accessor.componentType]
        return np.frombuffer(blob, dtype=dtype, count=accessor.count * width,
                             offset=view.byteOffset + (accessor.byteOffset or 0)).reshape(accessor.count, width)

    xyz, feature = [], []
    for primitive in gltf.meshes[0].primitives:
        points = read(primitive.attributes.POSITION, 3).astype(np.float64)
        xyz.append(points)
        fid = getattr(primitive.attributes, "_FEATURE_ID_0", None)
        feature.append(read(fid, 1)[:, 0].astype(np.int64) if fid is not None else np.full(len(points), -1))
    return {"xyz": np.concatenate(xyz), "feature": np.concatenate(feature), "gltf": gltf, "blob": blob}


def _property_strings(gltf: pygltflib.GLTF2, blob: bytes, name: str) -> list[str]:
    if "EXT_structural_metadata" not in gltf.extensions:  # a tile without buildings
        return []
    table = gltf.extensions["EXT_structural_metadata"]["propertyTables"][0]
    spec = table["properties"][name]
    values, offsets = (gltf.bufferViews[spec[k]] for k in ("values", "stringOffsets"))
    ends = np.frombuffer(blob, dtype=np.uint32, count=table["count"] + 1, offset=offsets.byteOffset)
    data = blob[values.byteOffset:values.byteOffset + values.byteLength]
    return [data[a:b].decode("utf-8") for a, b in zip(ends[:-1], ends[1:])]


def _inside(inner: list[float], outer: list[float], tol: float = 1e-9) -> bool:
    return (inner[0] >= outer[0] - tol and inner[1] >= outer[1] - tol and inner[2] <= outer[2] + tol
            and inner[3] <= outer[3] + tol and inner[4] >= outer[4] - 1e-3 and inner[5] <= outer[5] + 1e-3)


def test_every_glb_passes_the_khronos_gltf_validator(chain):
    result = subprocess.run(["node", str(VIEWER / "validate-gltf.mjs"), str(chain["folder"])], capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    summary = json.loads(result.stdout)
    assert summary["files"] == chain["tiles"]["TILES"] == len(list(chain["folder"].rglob("*.glb")))
    assert summary["errors"] == 0, json.dumps(summary["failures"], ensure_ascii=False)[:3000]
    assert summary["warnings"] == 0, summary["codes"]


def test_tileset_structure(chain):
    """3D Tiles 1.1; each region holds its content and its children; errors shrink to 0 at the leaves."""
    document = json.loads((chain["folder"] / "tileset.json").read_text(encoding="utf-8"))
    assert document["asset"]["version"] == "1.1"
    georef = Georeference(CRS)
    tiles = list(_tiles(document["root"], np.eye(4)))
    leaves = [t for t, _, _ in tiles if not t.get("children")]
    assert len(tiles) == chain["tiles"]["TILES"] and len(leaves) >= 4
    assert document["geometricError"] >= document["root"]["geometricError"] > 0
    levels = set()
    for tile, world, parent in tiles:
        region = tile["boundingVolume"]["region"]
        assert region[0] < region[2] and region[1] < region[3] and region[4] < region[5]
        if parent is not None:
            assert _inside(region, parent["boundingVolume"]["region"])
            assert tile["geometricError"] <= parent["geometricError"]
        if not tile.get("children"):
            assert tile["geometricError"] == 0 and "content" in tile
        else:
            assert tile["geometricError"] > 0 and tile["refine"] == "REPLACE"
        if "content" in tile:
            levels.add(tile["content"]["uri"].split("/")[1])
            xyz = gltf_to_model(georef, world, _positions(chain["folder"] / tile["content"]["uri"])["xyz"])
            lon, lat, h = georef._geographic.transform(xyz[:, 0], xyz[:, 1], xyz[:, 2])
            points = [np.radians(lon).min(), np.radians(lat).min(), np.radians(lon).max(), np.radians(lat).max(),
                      h.min(), h.max()]
            assert _inside(points, region)
    assert levels == {"0", "1", "2"}  # 128 m leaves over a 400 m square: a root, 4 tiles, 16 leaves


def test_vertices_round_trip_to_the_model_within_a_centimetre(chain):
    document = json.loads((chain["folder"] / "tileset.json").read_text(encoding="utf-8"))
    georef = Georeference(CRS)
    ds = ogr.Open(chain["tin"])
    tin = np.array([p for f in ds.GetLayer() for p in f.GetGeometryRef().GetGeometryRef(0).GetPoints()])
    ds = ogr.Open(chain["lod1"])
    faces = {}
    for f in ds.GetLayer():
        polygon = f.GetGeometryRef()
        for ring in range(polygon.GetGeometryCount()):  # roof triangles use the holes' corners too
            faces.setdefault(f.GetField(model.WIT_ID), []).extend(polygon.GetGeometryRef(ring).GetPoints())
    tin_tree = shapely.STRtree(shapely.points(tin[:, :2]))
    buildings_seen = 0
    for tile, world, _ in _tiles(document["root"], np.eye(4)):
        if tile.get("children"):
            continue
        content = _positions(chain["folder"] / tile["content"]["uri"])
        xyz = gltf_to_model(georef, world, content["xyz"])
        ground = content["feature"] < 0
        nearest = tin_tree.query_nearest(shapely.points(xyz[ground, :2]), all_matches=False)[1]
        assert np.abs(tin[nearest] - xyz[ground]).max() < 0.01
        ids = _property_strings(content["gltf"], content["blob"], "wit_id")
        for number, wit_id in enumerate(ids):
            corners = np.array(faces[wit_id])
            mine = xyz[content["feature"] == number]
            distance = np.sqrt(((mine[:, None, :] - corners[None, :, :]) ** 2).sum(axis=2)).min(axis=1)
            assert distance.max() < 0.01, wit_id
        buildings_seen += len(ids)
    assert buildings_seen == chain["buildings"]  # every building once in the full-detail tiles


def test_buildings_carry_their_attributes_and_korean_names(chain):
    ds = ogr.Open(chain["lod1"])
    layer = ds.GetLayer()
    layer.SetAttributeFilter(f"{model.FACE_TYPE} = 'ground'")
    names = {f.GetField(model.WIT_ID): f.GetField("BULD_NM") or "" for f in layer}
    assert any(names.values())
    checked = 0
    for path in (chain["folder"] / "tiles").rglob("*.glb"):
        content = _positions(path)
        if "EXT_structural_metadata" not in content["gltf"].extensions:
            continue
        metadata = content["gltf"].extensions["EXT_structural_metadata"]
        properties = metadata["schema"]["classes"]["building"]["properties"]
        assert properties[model.HEIGHT]["componentType"] == "FLOAT64" and properties["BULD_NM"]["type"] == "STRING"
        assert {model.WIT_ID, model.HEIGHT, model.HEIGHT_SOURCE, model.STOREYS_ABOVE, model.STOREYS_BELOW} <= set(properties)
        ids = _property_strings(content["gltf"], content["blob"], "wit_id")
        if "BULD_NM" in metadata["propertyTables"][0]["properties"]:
            for wit_id, name in zip(ids, _property_strings(content["gltf"], content["blob"], "BULD_NM")):
                assert name == names[wit_id]
                checked += bool(name)
    assert checked > 0


def test_upper_tiles_reuse_smaller_mip_levels_of_the_same_atlases(chain):
    textures = chain["folder"] / "textures"
    originals = {p.name for p in Path(chain["textures"]).iterdir() if p.suffix == ".jpg"}
    copies = {p.name for p in textures.iterdir()}
    mips = {name for name in copies if "_mip" in name}
    assert copies - mips <= originals and mips
    for name in mips:
        stem, level = name.rsplit("_mip", 1)
        original = gdal.Open(str(textures / f"{stem}.jpg"))
        level = int(level.split(".")[0])
        mip = gdal.Open(str(textures / name))
        assert (mip.RasterXSize, mip.RasterYSize) == (max(1, original.RasterXSize >> level),
                                                      max(1, original.RasterYSize >> level))


def test_viewer_in_headless_chromium_shows_the_model_and_a_buildings_attributes(chain, tmp_path):
    report, picture = view_in_chromium(chain["folder"], tmp_path, click=True)
    background = picture[0]  # the top-left corner is sky
    drawn = np.abs(picture - background).sum(axis=1) > 30
    assert drawn.mean() > 0.3  # the model fills a good part of the view
    colours = picture[drawn]
    assert colours.std(axis=0).mean() > 20  # textured: many colours, not one flat shade
    assert (colours[:, 1] > colours[:, 0] + 10).mean() > 0.02  # green of the orthophoto's trees and lawns
    info = report["info"]
    assert info and info["rows"]["wit_id"].startswith("BLD_")
    ds = ogr.Open(chain["lod1"])
    layer = ds.GetLayer()
    layer.SetAttributeFilter(f"{model.FACE_TYPE} = 'ground' AND {model.WIT_ID} = '{info['rows']['wit_id']}'")
    ground = layer.GetNextFeature()
    assert float(info["rows"][model.HEIGHT]) == pytest.approx(ground.GetField(model.HEIGHT))
    name = ground.GetField("BULD_NM")
    assert name and info["title"] == name == info["rows"]["BULD_NM"]  # Korean, intact


def test_bad_inputs_and_outputs_are_refused_before_anything_is_written(chain, tmp_path):
    lod1, tin, textures = chain["lod1"], chain["tin"], chain["textures"]
    with pytest.raises(InputError, match="LoD1 buildings, the TIN, or both"):
        export_tileset(None, None, textures, str(tmp_path / "a"))
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="not empty"):
        export_tileset(lod1, tin, textures, str(busy))
    assert [p.name for p in busy.iterdir()] == ["notes.txt"]
    with pytest.raises(InputError, match="holds the input"):
        export_tileset(lod1, tin, textures, str(Path(textures).parent))
    with pytest.raises(InputError, match="not a projected CRS"):
        export_tileset(lod1, tin, textures, str(tmp_path / "b"), crs="EPSG:4326")
    with pytest.raises(InputError, match="EPSG:5186"):
        export_tileset(lod1, tin, textures, str(tmp_path / "c"), crs="EPSG:5179")
    with pytest.raises(InputError, match=r"Layer 'tin' .* lacks the field\(s\) wit_id, wit_face, wit_face_no, wit_height "
                                         r"of the LoD1 faces \(wit:extrudebuildings\)"):
        export_tileset(tin, None, None, str(tmp_path / "d"))
    assert not any((tmp_path / n).exists() for n in "abcd")


def test_cancel_leaves_nothing(chain, tmp_path):
    class CancelLater(Feedback):
        def __init__(self):
            self.checks = 0

        def is_canceled(self) -> bool:
            self.checks += 1
            return self.checks > 8

    with pytest.raises(CanceledError):
        export_tileset(chain["lod1"], chain["tin"], chain["textures"], str(tmp_path / "out"), feedback=CancelLater(),
                       config=TilesetConfig(leaf_size=64.0))
    assert list(tmp_path.iterdir()) == []


def test_terrain_only_and_a_rerun_replaces_the_tileset(chain, tmp_path):
    out = tmp_path / "terrain"
    first = export_tileset(None, chain["tin"], None, str(out), config=TilesetConfig(leaf_size=64.0))
    assert first.buildings == 0 and first.tin_triangles == chain["triangles"] and first.leaves > 4
    second = export_tileset(None, chain["tin"], None, str(out), config=TilesetConfig(leaf_size=1000.0))
    assert second.tiles == 1 and [p.name for p in (out / "tiles").iterdir()] == ["0"]


def test_gui_run_loads_the_results_as_a_group_with_3d_renderers(chain):
    """Processing's own post-processing (what the GUI runs after an algorithm) loads the queued layers."""
    from processing.gui.Postprocessing import handleAlgorithmResults
    from qgis._3d import QgsVectorLayer3DRenderer
    from qgis.core import QgsAbstract3DSymbol, QgsApplication, QgsProcessingContext, QgsProcessingFeedback, QgsProject

    from wit_citymodel.processing_provider.load_results import load_results

    project = QgsProject()
    context = QgsProcessingContext()
    context.setProject(project)
    names = load_results(context, lod1=chain["lod1"], tin=chain["tin"],
                         tileset=str(chain["folder"] / "tileset.json"))
    assert names == ["LoD1 buildings", "Terrain (TIN)"]  # QGIS 3.22: no tiled-scene layer before 3.34
    algorithm = QgsApplication.processingRegistry().algorithmById("wit:export3dtiles")
    assert handleAlgorithmResults(algorithm, context, QgsProcessingFeedback(), showResults=True)
    group = project.layerTreeRoot().findGroup("WIT city model")
    assert group is not None and [n.name() for n in group.findLayers()] == names
    buildings = project.mapLayersByName("LoD1 buildings")[0]
    assert buildings.featureCount() == chain["buildings"]  # one footprint per building
    renderer = buildings.renderer3D()
    assert isinstance(renderer, QgsVectorLayer3DRenderer)
    extrusion = renderer.symbol().dataDefinedProperties().property(QgsAbstract3DSymbol.PropertyExtrusionHeight)
    assert extrusion.field() == model.HEIGHT
    terrain = project.mapLayersByName("Terrain (TIN)")[0]
    assert terrain.featureCount() == chain["triangles"] and terrain.renderer3D() is not None


def test_a_leaf_without_triangles_gets_an_empty_patch():
    """A leaf meeting no TIN triangle (found on real roads: a tile's sliver) samples NaN heights and the
    neutral colour, instead of failing the export."""
    from wit_plugin.tiles3d.coarse import NO_COLOUR, leaf_patch
    from wit_plugin.tiles3d.store import TriangleRows

    empty = TriangleRows(np.empty((0, 3, 3)), np.empty(0, dtype=object), np.empty(0, dtype=np.int64),
                         np.empty((0, 3, 2)), np.empty(0, dtype=np.int64))
    patch = leaf_patch(empty, (0.0, 0.0, 64.0, 64.0), 4, 8, None)
    assert np.isnan(patch.heights).all() and patch.heights.shape == (5, 5)
    assert patch.image.shape == (8, 8, 3) and (patch.image == NO_COLOUR).all()
