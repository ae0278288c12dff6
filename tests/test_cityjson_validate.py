"""wit_plugin.cityjson.validate on bad files: each class of problem, made from a valid file, found and named (the
check, the object, the line of a sequence); the valid file stays valid."""
from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from test_citygml import A, B, make_inputs

from wit_plugin.cityjson import writer as cityjson
from wit_plugin.cityjson.validate import validate_cityjson_files
from wit_plugin.infra.errors import InputError


@pytest.fixture(scope="module")
def model(tmp_path_factory) -> tuple[Path, dict]:
    folder = tmp_path_factory.mktemp("valid")
    out = folder / "city.city.json"
    cityjson.write_cityjson(make_inputs(folder / "in"), str(out))
    return out, json.loads(out.read_text(encoding="utf-8"))


def _check(model, tmp_path: Path, change) -> list:
    """The errors found in the model changed by ``change(document)`` (written beside the textures)."""
    out, doc = model
    broken = copy.deepcopy(doc)
    change(broken)
    path = out.parent / f"broken_{tmp_path.name}.city.json"
    path.write_text(json.dumps(broken, ensure_ascii=False), encoding="utf-8")
    try:
        (report,) = validate_cityjson_files([str(path)])
    finally:
        path.unlink()
    return [(i.check, i.gml_id, i.message) for i in report.issues if i.severity == "error"]


def _solid(doc, wit_id):
    return doc["CityObjects"][wit_id]["geometry"][0]


def _lift_roof_corner(doc, millimetres):
    """A's roof's first corner moved up (a new vertex: the walls keep the old one)."""
    ring = _solid(doc, A["wit_id"])["boundaries"][0][1][0]
    x, y, z = doc["vertices"][ring[0]]
    doc["vertices"].append([x, y, z + millimetres])
    ring[0] = len(doc["vertices"]) - 1


def test_the_valid_file_is_valid(model):
    (report,) = validate_cityjson_files([str(model[0])])
    assert report.valid and report.details == "valid (schema, ids, references, geometry, textures)"


@pytest.mark.parametrize("name, change, check, owner, words", [
    ("schema: a lod that is no CityGML lod",
     lambda d: _solid(d, A["wit_id"]).update(lod="7"), "schema", A["wit_id"],
     f"CityObjects.{A['wit_id']}.geometry[0]: must be valid exactly by one definition"),
    ("schema: a city object type CityJSON has not",
     lambda d: d["CityObjects"][B["wit_id"]].update(type="Castle"), "schema", B["wit_id"], "'Castle'"),
    ("a face taken out: the solid has a hole",
     lambda d: _solid(d, A["wit_id"])["boundaries"][0].pop(3), "solid-closed", A["wit_id"], "not closed"),
    ("every face reversed: inside out",
     lambda d: _solid(d, A["wit_id"]).update(boundaries=[[[ring[::-1] for ring in s] for s in
                                                           _solid(d, A["wit_id"])["boundaries"][0]]]),
     "solid-orientation", A["wit_id"], "inside out"),
    ("a roof corner lifted 5 cm: not planar", lambda d: _lift_roof_corner(d, 50), "planarity", A["wit_id"],
     "not planar"),
    ("a vertex index beyond the vertices",
     lambda d: _solid(d, B["wit_id"])["boundaries"][0][0][0].__setitem__(0, 10 ** 6), "vertex-index", B["wit_id"],
     "does not exist"),
    ("a parent that is no city object",
     lambda d: d["CityObjects"][A["wit_id"]].update(parents=["EMD_0"]), "reference", A["wit_id"], "EMD_0"),
    ("a group member that does not name its group",
     lambda d: d["CityObjects"][B["wit_id"]].pop("parents"), "reference", "EMD_11110102", "does not list"),
    ("a TIN triangle with two corners on one point",
     lambda d: _solid(d, "DEM_tin")["boundaries"][0][0].__setitem__(1, _solid(d, "DEM_tin")["boundaries"][0][0][0]),
     "degenerate-triangle", "DEM_tin", "degenerate"),
    ("a texture image that is not there",
     lambda d: d["appearance"]["textures"][0].update(image="city_textures/nowhere.jpg"), "texture-image", None,
     "nowhere.jpg"),
    ("texture values for a ring of another length",
     lambda d: _solid(d, A["wit_id"])["texture"]["rgbTexture"]["values"][0][1][0].pop(), "texture-coordinates",
     A["wit_id"], "per corner"),
    ("semantic values for fewer surfaces",
     lambda d: _solid(d, A["wit_id"])["semantics"]["values"][0].pop(), "semantics", A["wit_id"], "semantic values"),
])
def test_each_problem_is_found(model, tmp_path, name, change, check, owner, words):
    errors = _check(model, tmp_path, change)
    assert any(c == check and o == owner and words in m for c, o, m in errors), errors


def test_a_repeated_id_in_one_file(model, tmp_path):
    out, _ = model
    text = out.read_text(encoding="utf-8")
    first = text.index(f'"{B["wit_id"]}":')
    path = out.parent / "twice.city.json"
    path.write_text(text.replace(f'"{B["wit_id"]}":', f'"{A["wit_id"]}":', 1) if first else text, encoding="utf-8")
    (report,) = validate_cityjson_files([str(path)])
    path.unlink()
    assert [(i.check, i.gml_id) for i in report.issues if i.check == "duplicate-id"] == [("duplicate-id", A["wit_id"])]


def test_sequences_name_the_line(model, tmp_path):
    out, _ = model
    sequence = tmp_path / "city.city.jsonl"
    cityjson.write_cityjson(make_inputs(tmp_path / "in"), str(sequence))
    lines = sequence.read_text(encoding="utf-8").splitlines()
    broken = tmp_path / "broken.city.jsonl"
    broken.write_text("\n".join(lines + [lines[1], "{not json", '{"type": "CityJSON"}']) + "\n", encoding="utf-8")
    (report,) = validate_cityjson_files([str(broken)])
    found = {(i.check, i.line) for i in report.issues if i.severity == "error"}
    assert ("duplicate-id", 8) in found and ("json", 9) in found and ("json", 10) in found, report.issues
    feature_first = tmp_path / "feature_first.city.jsonl"
    feature_first.write_text("\n".join(lines[1:]) + "\n", encoding="utf-8")
    (report,) = validate_cityjson_files([str(feature_first)])
    assert [(i.check, i.line) for i in report.issues] == [("json", 1)]
    assert "not a CityJSON object" in report.issues[0].message


@pytest.mark.parametrize("content, words", [
    (b"", "empty"), (b"  \n ", "only white space"), (b"<?xml version='1.0'?><CityModel/>", "XML (CityGML?)"),
    (b'{"type": "FeatureCollection", "features": []}', "GeoJSON"), (b'{"type": "CityJSON", ', "not valid JSON"),
    (b"\x89PNG\r\n", "not JSON"),
])
def test_files_that_are_no_cityjson(tmp_path, content, words):
    path = tmp_path / "x.city.json"
    path.write_bytes(content)
    (report,) = validate_cityjson_files([str(path)])
    assert not report.valid and len(report.issues) == 1 and words in report.issues[0].message


def test_no_file_or_a_missing_one(tmp_path):
    with pytest.raises(InputError, match="No CityJSON files"):
        validate_cityjson_files([])
    with pytest.raises(InputError, match="does not exist"):
        validate_cityjson_files([str(tmp_path / "missing.city.json")])
