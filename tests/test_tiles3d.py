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
from conftest import ensure_wit_provider, view_in_chromium
from osgeo import gdal, ogr

from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.sample import SampleConfig, generate_sample
from wit_plugin.tiles3d import TilesetConfig, export_tileset
from wit_plugin.tiles3d.check import check_tileset, read_glb
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
    mosaic = run("wit:mergerasters", {"INPUT": geo["OUTPUT_LAYERS"], "OVERLAP": 1, "OUTPUT": str(out / "mosaic.tif")})
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


def _view_bytes(gltf: pygltflib.GLTF2, blob: bytes, number: int) -> bytes:
    """A buffer view's bytes, decoded when the web profile compressed it (EXT_meshopt_compression)."""
    view = gltf.bufferViews[number]
    meshopt = (view.extensions or {}).get("EXT_meshopt_compression")
    if meshopt is None:
        return blob[view.byteOffset or 0:(view.byteOffset or 0) + view.byteLength]
    import meshoptimizer

    data = blob[meshopt["byteOffset"]:meshopt["byteOffset"] + meshopt["byteLength"]]
    if meshopt["mode"] == "ATTRIBUTES":
        return meshoptimizer.decode_vertex_buffer(meshopt["count"], meshopt["byteStride"], data).tobytes()
    indices = meshoptimizer.decode_index_buffer(meshopt["count"], 4, data)
    return indices.astype(np.uint16 if meshopt["byteStride"] == 2 else np.uint32).tobytes()


def _positions(path: Path) -> dict[str, np.ndarray]:
    """POSITION (dequantized, in the tile's frame) and _FEATURE_ID_0 (or -1) of every primitive of a .glb,
    its triangles' corners, the document and its binary chunk; reads both profiles."""
    gltf = pygltflib.GLTF2().load_binary(str(path))
    blob = gltf.binary_blob()

    def read(index: int, width: int) -> np.ndarray:
        accessor = gltf.accessors[index]
        view = gltf.bufferViews[accessor.bufferView]
        dtype = np.dtype({5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5120: np.int8}[accessor.componentType])
        data = _view_bytes(gltf, blob, accessor.bufferView)
        values = np.ndarray((accessor.count, width), dtype, buffer=data, offset=accessor.byteOffset or 0,
                            strides=(view.byteStride or dtype.itemsize * width, dtype.itemsize)).astype(np.float64)
        if accessor.normalized:
            values = np.maximum(values / np.iinfo(dtype).max, -1.0)
        return values

    node = gltf.nodes[0]
    scale, offset = np.array(node.scale or [1.0] * 3), np.array(node.translation or [0.0] * 3)
    xyz, feature, corners = [], [], []
    for primitive in gltf.meshes[0].primitives:
        points = read(primitive.attributes.POSITION, 3) * scale + offset
        xyz.append(points)
        corners.append(points[read(primitive.indices, 1)[:, 0].astype(np.int64)].reshape(-1, 3, 3))
        fid = getattr(primitive.attributes, "_FEATURE_ID_0", None)
        feature.append(read(fid, 1)[:, 0].astype(np.int64) if fid is not None else np.full(len(points), -1))
    return {"xyz": np.concatenate(xyz), "feature": np.concatenate(feature), "corners": corners, "gltf": gltf,
            "blob": blob}


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
    check = check_tileset(chain["folder"])  # what the official 3D Tiles validator checks, ours
    assert check.problems == [] and check.tiles == len(tiles) and check.property_tables >= len(leaves) // 2


def test_a_layer_without_floor_values_gives_complete_property_tables(chain, tmp_path):
    """The official 3D Tiles validator once rejected tiles whose buildings had no storeys at all ("The property
    table does not define property wit_storeys_below"): every table now holds every numeric property."""
    lod1 = tmp_path / "lod1.gpkg"
    gdal.VectorTranslate(str(lod1), chain["lod1"])
    ds = ogr.Open(str(lod1), 1)
    ds.ExecuteSQL(f"UPDATE {step_layers.LOD1_LAYER} "
                  f"SET {step_layers.STOREYS_ABOVE} = NULL, {step_layers.STOREYS_BELOW} = NULL")
    ds = None
    out = tmp_path / "3dtiles"
    export_tileset(str(lod1), chain["tin"], chain["textures"], str(out), config=TilesetConfig(leaf_size=128.0))
    check = check_tileset(out)
    assert check.problems == [] and check.property_tables > 0
    for path in out.rglob("*.glb"):
        gltf, blob = read_glb(path.read_bytes())
        for table in gltf.get("extensions", {}).get("EXT_structural_metadata", {}).get("propertyTables", []):
            assert {step_layers.STOREYS_ABOVE, step_layers.STOREYS_BELOW, step_layers.HEIGHT} \
                <= set(table["properties"])


def test_buildings_kept_or_read_again_give_the_same_tiles(chain, tmp_path, monkeypatch):
    """Whether the coarse tiles draw their buildings from what their leaves read and made (the default) or read and
    make them again (one kept at a time: the bound of a city's run), every file of the tileset is the same."""
    from wit_plugin.tiles3d import store as store_module

    monkeypatch.setattr(store_module, "PARSED_BUILDINGS", 1)
    export_tileset(chain["lod1"], chain["tin"], chain["textures"], str(tmp_path / "again"),
                   config=TilesetConfig(leaf_size=128.0))
    ours = {p.relative_to(chain["folder"]): p.read_bytes() for p in chain["folder"].rglob("*") if p.is_file()}
    again = {p.relative_to(tmp_path / "again"): p.read_bytes() for p in (tmp_path / "again").rglob("*") if p.is_file()}
    assert len(ours) > 20 and sorted(ours) == sorted(again)
    assert [name for name in ours if ours[name] != again[name]] == []


def test_vertices_round_trip_to_the_model_within_a_centimetre(chain):
    _check_round_trip(chain, chain["folder"])


def _check_round_trip(chain: dict, folder: Path) -> None:
    """Every full-detail vertex lies within 1 cm of the TIN's or its building's faces' corners."""
    document = json.loads((folder / "tileset.json").read_text(encoding="utf-8"))
    georef = Georeference(CRS)
    ds = ogr.Open(chain["tin"])
    tin = np.array([p for f in ds.GetLayer() for p in f.GetGeometryRef().GetGeometryRef(0).GetPoints()])
    ds = ogr.Open(chain["lod1"])
    faces = {}
    for f in ds.GetLayer():
        polygon = f.GetGeometryRef()
        for ring in range(polygon.GetGeometryCount()):  # roof triangles use the holes' corners too
            faces.setdefault(f.GetField(step_layers.WIT_ID), []).extend(polygon.GetGeometryRef(ring).GetPoints())
    tin_tree = shapely.STRtree(shapely.points(tin[:, :2]))
    buildings_seen = 0
    for tile, world, _ in _tiles(document["root"], np.eye(4)):
        if tile.get("children"):
            continue
        content = _positions(folder / tile["content"]["uri"])
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


def _levels(tile: dict, world: np.ndarray, level: int = 0):
    """(tile, world matrix, level) for every tile, depth first."""
    matrix = world @ np.array(tile.get("transform", np.eye(4).ravel()), dtype=float).reshape(4, 4).T
    yield tile, matrix, level
    for child in tile.get("children", []):
        yield from _levels(child, matrix, level + 1)


def _covered(folder: Path, points: np.ndarray, ground_only: bool) -> dict[int, np.ndarray]:
    """Per level of the tileset: which ``points`` (x, y in the model CRS) its tiles draw on (their triangles
    seen from above), of the ground alone (primitives without buildings) or of ground and buildings."""
    document = json.loads((folder / "tileset.json").read_text(encoding="utf-8"))
    georef = Georeference(CRS)
    covered: dict[int, np.ndarray] = {}
    leaves = set()
    for tile, world, level in _levels(document["root"], np.eye(4)):
        hit = covered.setdefault(level, np.zeros(len(points), dtype=bool))
        if not tile.get("children"):
            leaves.add(level)
        if "content" not in tile:
            continue
        content = _positions(folder / tile["content"]["uri"])
        primitives = content["gltf"].meshes[0].primitives
        tris = [gltf_to_model(georef, world, corners.reshape(-1, 3)).reshape(-1, 3, 3)
                for corners, primitive in zip(content["corners"], primitives)
                if not (ground_only and getattr(primitive.attributes, "_FEATURE_ID_0", None) is not None)]
        if not tris:
            continue
        xy = np.concatenate(tris)[:, :, :2]
        area = np.abs(np.cross(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]))
        polygons = shapely.polygons(xy[area > 1e-6][:, [0, 1, 2, 0]])  # walls seen from above: no area
        hit[np.unique(shapely.STRtree(polygons).query(shapely.points(points), predicate="intersects")[0])] = True
    assert leaves == {max(covered)}  # the quadtree's leaves are all on its last level
    return covered


def test_every_level_covers_the_ground_its_leaves_cover(chain):
    """Rasterised level by level over a 1 m grid: the coarse terrain of every upper level alone (buildings may
    be left out from afar) covers every point the leaves draw, ground or roof. The TIN leaves the footprints
    out (the buildings stand there): before, the grid cells touching a footprint were dropped, and QGIS showed
    white squares in the ground wherever a coarse level was drawn."""
    ds = ogr.Open(chain["tin"])
    xmin, xmax, ymin, ymax = ds.GetLayer().GetExtent()
    assert ds.GetLayer().GetFeatureCount() > 0
    layer = ds.GetLayer()
    layer.SetAttributeFilter(f"{step_layers.TIN_SURFACE} = 'footprint'")
    assert layer.GetFeatureCount() == 0  # the footprints are holes in this TIN
    x, y = np.meshgrid(np.arange(xmin, xmax, 1.0) + 0.5, np.arange(ymin, ymax, 1.0) + 0.5)
    points = np.column_stack([x.ravel(), y.ravel()])
    everything = _covered(chain["folder"], points, ground_only=False)
    ground = _covered(chain["folder"], points, ground_only=True)
    leaf = max(everything)
    drawn = everything[leaf]
    assert drawn.mean() > 0.6 and (drawn & ~ground[leaf]).sum() > 1000  # roofs close the TIN's holes
    for level in range(leaf):
        missing = drawn & ~ground[level]
        assert missing.sum() == 0, f"level {level}: {missing.sum()} m² drawn by the leaves lack ground, e.g. " \
                                   f"{points[missing][:3].tolist()}"


def test_buildings_carry_their_attributes_and_korean_names(chain):
    ds = ogr.Open(chain["lod1"])
    layer = ds.GetLayer()
    layer.SetAttributeFilter(f"{step_layers.FACE_TYPE} = 'ground'")
    names = {f.GetField(step_layers.WIT_ID): f.GetField("BULD_NM") or "" for f in layer}
    assert any(names.values())
    checked = 0
    for path in (chain["folder"] / "tiles").rglob("*.glb"):
        content = _positions(path)
        if "EXT_structural_metadata" not in content["gltf"].extensions:
            continue
        metadata = content["gltf"].extensions["EXT_structural_metadata"]
        properties = metadata["schema"]["classes"]["building"]["properties"]
        assert properties[step_layers.HEIGHT]["componentType"] == "FLOAT64"
        assert properties["BULD_NM"]["type"] == "STRING"
        assert {step_layers.WIT_ID, step_layers.HEIGHT, step_layers.HEIGHT_SOURCE, step_layers.STOREYS_ABOVE,
                step_layers.STOREYS_BELOW} <= set(properties)
        ids = _property_strings(content["gltf"], content["blob"], "wit_id")
        if "BULD_NM" in metadata["propertyTables"][0]["properties"]:
            for wit_id, name in zip(ids, _property_strings(content["gltf"], content["blob"], "BULD_NM")):
                assert name == names[wit_id]
                checked += bool(name)
    assert checked > 0


def test_upper_tiles_reuse_smaller_mip_levels_of_the_same_atlases(chain):
    textures = chain["folder"] / "textures"
    originals = {p.name for p in Path(chain["textures"]).iterdir() if p.suffix in (".jpg", ".png")}
    copies = {p.name for p in textures.iterdir()}
    mips = {name for name in copies if "_mip" in name}
    assert copies - mips <= originals and mips
    assert {name.split("_mip")[0] for name in mips if name.startswith("facade_")}  # facades' too
    for name in mips:
        stem, level = name.rsplit("_mip", 1)
        level, ext = level.split(".")
        original = gdal.Open(str(textures / f"{stem}.{ext}"))
        level = int(level)
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
    layer.SetAttributeFilter(f"{step_layers.FACE_TYPE} = 'ground' "
                             f"AND {step_layers.WIT_ID} = '{info['rows']['wit_id']}'")
    ground = layer.GetNextFeature()
    assert float(info["rows"][step_layers.HEIGHT]) == pytest.approx(ground.GetField(step_layers.HEIGHT))
    name = ground.GetField("BULD_NM")
    assert name and info["title"] == name == info["rows"]["BULD_NM"]  # Korean, intact


def test_generated_facades_are_textured_walls_marked_and_switched_off_in_the_viewer(chain, tmp_path):
    """Walls carry their facade image (repeating along the wall, lit), their vertices are marked _FACADE and the
    buildings say so in their metadata; the viewer's switch (a real click) draws the same walls plain."""
    walls = 0
    for path in (chain["folder"] / "tiles").rglob("*.glb"):
        gltf = pygltflib.GLTF2().load_binary(str(path))
        for primitive in gltf.meshes[0].primitives:
            material = gltf.materials[primitive.material]
            if not (material.name or "").startswith("facade_"):
                continue
            walls += 1
            texture = gltf.textures[material.pbrMetallicRoughness.baseColorTexture.index]
            sampler = gltf.samplers[texture.sampler]
            assert (sampler.wrapS, sampler.wrapT) == (10497, 33071)  # REPEAT along, CLAMP up
            assert "KHR_materials_unlit" not in (material.extensions or {}) and material.doubleSided
            assert primitive.attributes.NORMAL is not None and primitive.attributes._FACADE is not None
        if "EXT_structural_metadata" in gltf.extensions:
            properties = gltf.extensions["EXT_structural_metadata"]["schema"]["classes"]["building"]["properties"]
            assert {step_layers.FACADE, step_layers.FACADE_STYLE, step_layers.FACADE_STOREYS} <= set(properties)
    assert walls > 10
    query = "?target=127.1020,37.4876,20&distance=180&pitch=-10"
    report, on = view_in_chromium(chain["folder"], tmp_path / "on", query=query)
    report_off, off = view_in_chromium(chain["folder"], tmp_path / "off", query=query, options=("--no-facades",))
    assert report_off["facadesShown"] is False
    changed = np.abs(on - off).sum(axis=1) > 30
    assert 0.03 < changed.mean() < 0.8  # the walls, not the ground and roofs
    grey = off[changed].max(axis=1) - off[changed].min(axis=1) < 40  # the plain beige, lit or in shade
    assert grey.mean() > 0.8 and (on[changed].max(axis=1) - on[changed].min(axis=1) < 40).mean() < grey.mean()


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
    with pytest.raises(InputError, match=r"Layer 'tin' .* lacks the field\(s\) wit_id, wit_face, wit_face_no, "
                                         r"wit_height of the LoD1 faces \(wit:extrudebuildings\)"):
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


@pytest.mark.qgis_facing
def test_gui_run_loads_the_results_as_a_group_with_3d_renderers(chain, monkeypatch):
    """Processing's own post-processing (what the GUI runs after an algorithm) loads the queued layers:
    the LoD1 buildings and the TIN, and from QGIS 3.34 on (tiled-scene layers) the tileset too, each with
    the 3D renderer that shows it in a 3D map view."""
    from qgis.core import Qgis, QgsProject

    tiled_scenes = Qgis.QGIS_VERSION_INT >= 33400
    project = QgsProject()
    try:
        _check_gui_loading(chain, monkeypatch, project, tiled_scenes)
    finally:
        project.clear()  # its layers go now, not after QGIS has shut down (that segfaulted at exit)


def _check_gui_loading(chain, monkeypatch, project, tiled_scenes: bool) -> None:
    from processing.gui.Postprocessing import handleAlgorithmResults
    from qgis._3d import QgsVectorLayer3DRenderer
    from qgis.core import (
        QgsAbstract3DSymbol,
        QgsApplication,
        QgsProcessingContext,
        QgsProcessingFeedback,
    )
    from qgis.PyQt import sip
    from wit_citymodel.processing_provider.load_results import load_results

    context = QgsProcessingContext()
    context.setProject(project)
    names = load_results(context, lod1=chain["lod1"], tin=chain["tin"],
                         tileset=str(chain["folder"] / "tileset.json"))
    assert names == ["LoD1 buildings", "Terrain (TIN)"] + (["3D Tiles"] if tiled_scenes else [])
    algorithm = QgsApplication.processingRegistry().algorithmById("wit:export3dtiles")
    # no layer tree view here (QGIS 3.44's handler would pass pytest-qgis's mock iface's to C++)
    monkeypatch.setattr("processing.gui.Postprocessing.iface", None, raising=False)
    assert handleAlgorithmResults(algorithm, context, QgsProcessingFeedback())  # 3.44 has no showResults
    group = project.layerTreeRoot().findGroup("WIT city model")
    assert group is not None and [n.name() for n in group.findLayers()] == names
    buildings = project.mapLayersByName("LoD1 buildings")[0]
    assert buildings.featureCount() == chain["buildings"]  # one footprint per building
    renderer = buildings.renderer3D()
    assert renderer is not None and renderer.type() == "vector"
    renderer = sip.cast(renderer, QgsVectorLayer3DRenderer)  # 3.44's bindings return the base class
    extrusion = renderer.symbol().dataDefinedProperties().property(QgsAbstract3DSymbol.PropertyExtrusionHeight)
    assert extrusion.field() == step_layers.HEIGHT
    terrain = project.mapLayersByName("Terrain (TIN)")[0]
    assert terrain.featureCount() == chain["triangles"] and terrain.renderer3D() is not None
    if tiled_scenes:
        from qgis._3d import QgsTiledSceneLayer3DRenderer

        tileset = project.mapLayersByName("3D Tiles")[0]
        assert tileset.isValid() and tileset.renderer3D() is not None
        assert tileset.renderer3D().type() == QgsTiledSceneLayer3DRenderer().type()
        picture = _render_2d(tileset, buildings.extent(), buildings.crs())
        assert (picture != 255).any(axis=-1).mean() > 0.2, "the tileset draws (almost) nothing in 2D"


def _render_2d(layer, extent, crs, size: int = 256) -> np.ndarray:
    """``layer`` drawn on a white 2D map of ``extent`` (in ``crs``): its (size, size, 3) RGB pixels."""
    from qgis.core import QgsMapRendererSequentialJob, QgsMapSettings
    from qgis.PyQt.QtCore import QSize
    from qgis.PyQt.QtGui import QColor, QImage

    settings = QgsMapSettings()
    settings.setLayers([layer])
    settings.setDestinationCrs(crs)
    settings.setExtent(extent)
    settings.setOutputSize(QSize(size, size))
    settings.setBackgroundColor(QColor(255, 255, 255))
    job = QgsMapRendererSequentialJob(settings)
    job.start()
    job.waitForFinished()
    image = job.renderedImage().convertToFormat(QImage.Format.Format_RGB888)
    row_bytes = image.bytesPerLine()
    data = np.frombuffer(image.constBits().asstring(row_bytes * size), dtype=np.uint8).reshape(size, row_bytes)
    return data[:, :size * 3].reshape(size, size, 3)


def test_a_leaf_without_triangles_gets_an_empty_patch():
    """A leaf meeting no TIN triangle (found on real roads: a tile's sliver) samples NaN heights and the
    neutral colour, instead of failing the export."""
    from wit_plugin.tiles3d.coarse import NO_COLOUR, leaf_patch
    from wit_plugin.tiles3d.store import TriangleRows

    empty = TriangleRows(np.empty((0, 3, 3)), np.empty(0, dtype=object), np.empty(0, dtype=np.int64),
                         np.empty((0, 3, 2)), np.empty(0, dtype=np.int64))
    patch = leaf_patch(empty, empty, (0.0, 0.0, 64.0, 64.0), 4, 8, None)
    assert np.isnan(patch.heights).all() and patch.heights.shape == (5, 5)
    assert patch.image.shape == (8, 8, 3) and (patch.image == NO_COLOUR).all()


@pytest.fixture(scope="module")
def web(chain):
    """The same tileset in the web profile, through Processing."""
    import processing

    result = processing.run("wit:export3dtiles", {"LOD1": chain["lod1"], "TIN": chain["tin"],
                                                  "TEXTURES": chain["textures"], "LEAF_SIZE": 128.0,
                                                  "WEB_PROFILE": True, "OUTPUT": str(chain["out"] / "3dtiles-web")})
    return Path(result["OUTPUT"])


def test_web_profile_passes_the_khronos_gltf_validator_and_is_smaller(chain, web):
    result = subprocess.run(["node", str(VIEWER / "validate-gltf.mjs"), str(web)], capture_output=True, text=True,
                            timeout=600)
    summary = json.loads(result.stdout)
    assert summary["files"] == chain["tiles"]["TILES"]
    assert summary["errors"] == 0, json.dumps(summary["failures"], ensure_ascii=False)[:3000]
    assert summary["warnings"] == 0, summary["codes"]
    default = {p.relative_to(chain["folder"]): p for p in chain["folder"].rglob("*") if p.is_file()}
    compressed = {p.relative_to(web): p for p in web.rglob("*") if p.is_file()}
    assert default.keys() == compressed.keys()  # the same tiles and images
    for name, path in default.items():
        if name.suffix != ".glb" and name.name != "tileset.json":
            assert path.read_bytes() == compressed[name].read_bytes(), name  # images copied as they are
    glb = [(p.stat().st_size, compressed[n].stat().st_size) for n, p in default.items() if n.suffix == ".glb"]
    binary = [(_binary_chunk(p), _binary_chunk(compressed[n])) for n, p in default.items() if n.suffix == ".glb"]
    # what the profile compresses, the geometry, shrinks by half; with the JSON (on these small tiles over a third of
    # the bytes: a primitive per facade image) the whole files shrink less
    assert sum(b for _, b in binary) < 0.6 * sum(a for a, _ in binary)  # (0.51 here; the coarse JPEGs stay)
    assert sum(b for _, b in glb) < 0.8 * sum(a for a, _ in glb)  # README: the 1 km sample
    for name in (n for n in compressed if n.suffix == ".glb"):
        gltf = pygltflib.GLTF2().load_binary(str(compressed[name]))
        assert {"EXT_meshopt_compression", "KHR_mesh_quantization"} <= set(gltf.extensionsRequired)
        assert all(v.buffer == 1 for v in gltf.bufferViews if v.extensions)  # geometry only in the fallback
        assert gltf.buffers[1].extensions["EXT_meshopt_compression"]["fallback"] is True
    document = json.loads((web / "tileset.json").read_text(encoding="utf-8"))
    assert document == json.loads((chain["folder"] / "tileset.json").read_text(encoding="utf-8"))


def _binary_chunk(path: Path) -> int:
    """Bytes of a .glb's binary chunk (its geometry, metadata and embedded images)."""
    data = path.read_bytes()
    return len(data) - 28 - int.from_bytes(data[12:16], "little")


def test_web_profile_keeps_every_triangle_and_building_within_a_centimetre(chain, web):
    _check_round_trip(chain, web)
    for path in chain["folder"].rglob("*.glb"):
        plain, small = _positions(path), _positions(web / path.relative_to(chain["folder"]))
        assert [len(c) for c in small["corners"]] == [len(c) for c in plain["corners"]]  # same triangles per primitive
        _same_buildings(plain, small)
        step = (small["gltf"].nodes[0].scale or [0.0])[0]  # no scale: float positions
        for before, after in zip(plain["corners"], small["corners"]):  # reordered for the vertex cache
            assert _matched(before, after, max(0.01, 1.5 * step))


def _matched(before: np.ndarray, after: np.ndarray, tolerance: float) -> bool:
    """Whether two lists of triangles (t, 3, 3) are alike up to their order (meshopt's index codec also
    rotates a triangle's corners, keeping its winding), each corner within ``tolerance``: the triangles'
    centroids and normals (twice their areas, which rotation keeps and a flipped winding negates), each
    coordinate and a random mix of them, agree once sorted (sorting moves no value by more than the
    largest difference of a pairing)."""
    def shape(t: np.ndarray) -> np.ndarray:
        return np.column_stack([t.mean(axis=1), np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])])

    a, b = shape(before), shape(after)
    side = max(np.abs(before).max(), 1.0)  # a normal's error: twice the side times the corners' error
    limit = np.array([tolerance] * 3 + [8 * side * tolerance] * 3)
    mix = np.random.default_rng(0).random(6) / limit
    return len(a) == len(b) and bool((np.abs(np.sort(a, axis=0) - np.sort(b, axis=0)) <= limit).all()) \
        and np.abs(np.sort(a @ mix) - np.sort(b @ mix)).max() <= 6


def _same_buildings(plain: dict, small: dict) -> None:
    assert _property_strings(small["gltf"], small["blob"], "wit_id") == \
        _property_strings(plain["gltf"], plain["blob"], "wit_id")


def test_web_profile_in_headless_chromium_shows_the_model_and_a_buildings_attributes(web, tmp_path):
    report, picture = view_in_chromium(web, tmp_path, click=True)
    drawn = np.abs(picture - picture[0]).sum(axis=1) > 30
    assert drawn.mean() > 0.3 and picture[drawn].std(axis=0).mean() > 20
    assert report["info"] and report["info"]["rows"]["wit_id"].startswith("BLD_")


def test_compress_glb_quantizes_within_half_a_step_and_keeps_the_triangles(tmp_path):
    from wit_plugin.tiles3d.glb import GlbBuilder
    from wit_plugin.tiles3d.web import compress_glb

    rng = np.random.default_rng(3)
    walls, roofs = rng.random((300, 3, 3)) * [256.0, 40.0, 256.0], rng.random((200, 3, 3)) * 256.0
    uv, feature = rng.random((200, 3, 2)), np.arange(300) % 7
    builder = GlbBuilder()
    builder.triangles(walls, builder.plain_material((200, 200, 200), lit=True), feature=feature, normals=True)
    builder.triangles(roofs, builder.photo_material(data=b"\xff\xd8", name="roof"), uv)
    plain = builder.to_bytes()
    folder = tmp_path
    (folder / "plain.glb").write_bytes(plain)
    (folder / "web.glb").write_bytes(compress_glb(plain))
    before, after = _positions(folder / "plain.glb"), _positions(folder / "web.glb")
    step = after["gltf"].nodes[0].scale[0]
    assert step == pytest.approx(256.0 / 65535, rel=1e-3)
    for old, new in zip(before["corners"], after["corners"]):  # the same triangles, each corner within half a step
        assert _matched(old, new, step / 2 + 1e-6)
    assert sorted(after["feature"][after["feature"] >= 0].tolist()) == \
        sorted(before["feature"][before["feature"] >= 0].tolist())
