"""Our tileset checker (wit_plugin.tiles3d.check) on good and bad examples: the metadata rules the official
3D Tiles validator applies (every property of a class in each property table, types, counts, offsets,
feature ids) and the structure rules (regions nested, errors falling, contents on disk); and the
writer's tables for a tile whose buildings have no value at all in some fields (the official
validator once rejected such a tile)."""
from __future__ import annotations

import copy
import json
import struct

import numpy as np
import pytest
from osgeo import ogr

from wit_plugin.infra import step_layers
from wit_plugin.tiles3d.check import check_glb_metadata, check_tileset, read_glb
from wit_plugin.tiles3d.glb import GlbBuilder
from wit_plugin.tiles3d.metadata import BUILDING_CLASS, INT32_NO_DATA, building_schema, property_columns

FIELDS = [(step_layers.WIT_ID, ogr.OFTString), (step_layers.HEIGHT, ogr.OFTReal),
          (step_layers.STOREYS_ABOVE, ogr.OFTInteger), (step_layers.STOREYS_BELOW, ogr.OFTInteger),
          ("BULD_NM", ogr.OFTString), ("BD_MGT_SN", ogr.OFTInteger64)]


def _glb(attributes: list[list]) -> tuple[dict, bytes]:
    """A glb of one triangle per building with the property table of ``attributes`` (rows in FIELDS order)."""
    schema = building_schema(FIELDS)
    ids = [row[0] for row in attributes]
    builder = GlbBuilder()
    corners = np.array([[[k, 0, 0], [k + 1, 0, 0], [k, 1, 0]] for k in range(len(ids))], dtype=float)
    builder.triangles(corners, builder.plain_material((200, 200, 200), lit=True), feature=np.arange(len(ids)),
                      normals=True)
    builder.property_table(schema, BUILDING_CLASS, property_columns(schema, ids, attributes))
    return read_glb(builder.to_bytes())


GOOD = [["BLD_1", 12.5, 4, None, "강남타워", 11680], ["BLD_2", 6.0, None, None, None, None]]


def _table(gltf: dict) -> dict:
    return gltf["extensions"]["EXT_structural_metadata"]["propertyTables"][0]


def test_a_good_table_passes_and_holds_every_numeric_property():
    gltf, blob = _glb(GOOD)
    problems, tables = check_glb_metadata(gltf, blob)
    assert problems == [] and tables == 1
    assert set(_table(gltf)["properties"]) == {"wit_id", "wit_height", "wit_storeys_above", "wit_storeys_below",
                                               "BULD_NM", "BD_MGT_SN"}


def test_a_tile_without_floor_fields_still_writes_them_as_no_data():
    """The validator's "The property table does not define property wit_storeys_below" no more."""
    gltf, blob = _glb([["BLD_1", 12.5, None, None, None, None], ["BLD_2", 6.0, None, None, None, None]])
    assert check_glb_metadata(gltf, blob) == ([], 1)
    table = _table(gltf)
    assert {"wit_storeys_above", "wit_storeys_below", "BD_MGT_SN"} <= set(table["properties"])
    view = gltf["bufferViews"][table["properties"]["wit_storeys_below"]["values"]]
    values = np.frombuffer(blob, dtype="<i4", count=2, offset=view["byteOffset"])
    assert values.tolist() == [INT32_NO_DATA, INT32_NO_DATA]
    assert "BULD_NM" not in table["properties"]  # all empty: left out, the class gives its default
    assert gltf["extensions"]["EXT_structural_metadata"]["schema"]["classes"]["building"]["properties"][
        "BULD_NM"]["default"] == ""


def _bad(change) -> list[str]:
    gltf, blob = _glb(GOOD)
    gltf = copy.deepcopy(gltf)
    blob = change(gltf, blob) or blob
    return check_glb_metadata(gltf, blob)[0]


def _drop(name):
    def change(gltf, blob):
        _table(gltf)["properties"].pop(name)
    return change


def _drop_with(name, spec_change):
    def change(gltf, blob):
        spec_change(_class(gltf)[name])
        _table(gltf)["properties"].pop(name)
    return change


def _class(gltf):
    return gltf["extensions"]["EXT_structural_metadata"]["schema"]["classes"]["building"]["properties"]


@pytest.mark.parametrize("change, message", [
    (_drop("wit_storeys_below"), "property wit_storeys_below is missing (a numeric property"),
    (_drop_with("BULD_NM", lambda spec: spec.pop("default")),
     "property BULD_NM is missing and the class gives no default"),
    (_drop_with("wit_height", lambda spec: spec.update(required=True)),
     "required property wit_height is missing"),
    (lambda g, b: _table(g).update(count=3), "values hold 16 bytes for 3 rows of SCALAR FLOAT64 (24 expected)"),
    (lambda g, b: _table(g)["properties"].update(extra={"values": 0}), "property extra is not declared"),
    (lambda g, b: _class(g)["wit_height"].update(componentType="FLOAT16"), "needs a componentType"),
    (lambda g, b: _class(g)["wit_height"].update(noData="none"), "noData 'none' is not a SCALAR value"),
    (lambda g, b: _class(g)["BULD_NM"].update(required=True), "a required property cannot have a default"),
    (lambda g, b: _table(g).update({"class": "house"}), "class 'house' is not in the schema"),
], ids=["numeric-missing", "text-missing-without-default", "required-missing", "count", "undeclared",
        "component-type", "no-data-type", "required-with-default", "unknown-class"])
def test_bad_tables_are_reported(change, message):
    problems = _bad(change)
    assert any(message in p for p in problems), problems


def _set_offsets(gltf: dict, blob: bytes, offsets: list[int]) -> bytes:
    view = gltf["bufferViews"][_table(gltf)["properties"]["BULD_NM"]["stringOffsets"]]
    data = bytearray(blob)
    struct.pack_into(f"<{len(offsets)}I", data, view["byteOffset"], *offsets)
    return bytes(data)


def test_bad_string_offsets_and_views_are_reported():
    length = len("강남타워".encode())
    assert any("not ascending" in p for p in _bad(lambda g, b: _set_offsets(g, b, [0, length, 2])))
    assert any(f"last string offset is {length - 1}" in p
               for p in _bad(lambda g, b: _set_offsets(g, b, [0, length - 1, length - 1])))
    assert any("not aligned to 8" in p for p in _bad(
        lambda g, b: g["bufferViews"][_table(g)["properties"]["wit_height"]["values"]].update(
            byteOffset=g["bufferViews"][_table(g)["properties"]["wit_height"]["values"]]["byteOffset"] + 4)))
    assert any("byteLength 0" in p for p in _bad(lambda g, b: g["bufferViews"][0].update(byteLength=0)))


def test_bad_feature_ids_are_reported():
    def more_ids(gltf, blob):
        gltf["meshes"][0]["primitives"][0]["extensions"]["EXT_mesh_features"]["featureIds"][0]["featureCount"] = 1
    assert any("2 distinct feature ids, featureCount 1" in p for p in _bad(more_ids))

    def small_table(gltf, blob):
        _table(gltf)["count"] = 1
        for spec in _table(gltf)["properties"].values():  # (the columns' lengths are not the point here)
            spec.pop("stringOffsets", None)
    assert any("feature ids 0–1 outside the table's 1 rows" in p for p in _bad(small_table))


def _tileset(tmp_path, child: dict, parent_error: float = 10.0):
    gltf_bytes = GlbBuilder()
    gltf_bytes.triangles(np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], dtype=float),
                         gltf_bytes.plain_material((1, 2, 3), lit=False))
    (tmp_path / "a.glb").write_bytes(gltf_bytes.to_bytes())
    region = [0.1, 0.2, 0.3, 0.4, 0.0, 100.0]
    root = {"boundingVolume": {"region": region}, "geometricError": parent_error, "refine": "REPLACE",
            "content": {"uri": "a.glb"}, "children": [child]}
    (tmp_path / "tileset.json").write_text(json.dumps({"asset": {"version": "1.1"}, "geometricError": 20.0,
                                                       "root": root}))
    return check_tileset(tmp_path)


def test_tileset_structure_problems_are_reported(tmp_path):
    good = {"boundingVolume": {"region": [0.15, 0.25, 0.2, 0.3, 1.0, 50.0]}, "geometricError": 0.0,
            "content": {"uri": "a.glb"}}
    result = _tileset(tmp_path, good)
    assert result.problems == [] and result.tiles == 2 and result.contents == 2
    assert result.tilesets == {"tileset.json": (tmp_path / "tileset.json").stat().st_size}
    assert "not inside its parent" in _tileset(tmp_path, dict(good, boundingVolume={"region": [
        0.05, 0.25, 0.2, 0.3, 1.0, 50.0]})).problems[0]
    assert "above its parent's 10.0" in _tileset(tmp_path, dict(good, geometricError=11.0)).problems[0]
    assert "content b.glb is missing" in _tileset(tmp_path, dict(good, content={"uri": "b.glb"})).problems[0]
    assert "transform is not 16" in _tileset(tmp_path, dict(good, transform=[1.0] * 15)).problems[0]
    external = dict(good, content={"uri": "sub/tileset.json"})
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "tileset.json").write_text(json.dumps({"asset": {"version": "1.1"}, "geometricError": 5.0,
                                                               "root": dict(good, geometricError=5.0, content={
                                                                   "uri": "../a.glb"})}))
    result = _tileset(tmp_path, external)
    assert "sub/tileset.json:root: geometricError 5.0 above its parent's 0.0" in result.problems[0]
    assert set(result.tilesets) == {"tileset.json", "sub/tileset.json"}
