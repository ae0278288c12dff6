"""Every JSON the core writes keeps Python's float formatting even after cjio rewrote the ``json`` module's
(process-wide, six decimals): regions of 3D Tiles written so no longer held their vertices, and the whole suite
failed after the CityJSON tests had imported cjio."""
from __future__ import annotations

import json

import numpy as np
import pytest

from wit_plugin.infra.io import jsontext


@pytest.fixture
def cjio_imported(monkeypatch):
    """The ``json`` module as cjio leaves it, put back after the test (monkeypatch)."""
    pytest.importorskip("cjio")
    from cjio.floatEncoder import FloatEncoder

    monkeypatch.setattr(json.encoder, "c_make_encoder", None)
    monkeypatch.setattr(json.encoder, "float", FloatEncoder, raising=False)  # shadows the built-in
    assert json.dumps(2.2183089050605216) != "2.2183089050605216"  # what it did to everyone's JSON
    return FloatEncoder


def test_floats_keep_their_shortest_repr_after_cjio_changed_the_json_module(cjio_imported):
    region = [2.2183089050605216, 0.6542505879501641, 14.26877994183451, -1.8674267530441284e-05]
    text = jsontext.dumps({"region": region, "id": "건물", "n": 3}, ensure_ascii=False, separators=(",", ":"))
    assert text == '{"region":[' + ",".join(repr(v) for v in region) + '],"id":"건물","n":3}'
    assert json.loads(text)["region"] == region
    assert json.encoder.float is cjio_imported and json.encoder.c_make_encoder is None  # theirs, left as it was


def test_a_glb_written_after_cjio_declares_its_exact_bounds(cjio_imported):
    """The glTF validator's ACCESSOR_MIN_MISMATCH of the suite: bounds written with six decimals."""
    import struct

    from wit_plugin.tiles3d.glb import GlbBuilder

    corners = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, -1.8674267530441284], [0.0, 1.0, 0.123456789]]])
    glb = GlbBuilder()
    glb.triangles(corners, glb.plain_material((200, 200, 200), lit=False, name="ground"))
    data = glb.to_bytes()
    (length,) = struct.unpack_from("<I", data, 12)  # the JSON chunk, after the 12-byte header
    document = json.loads(data[20:20 + length])
    position = document["accessors"][document["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    assert position["min"] == [float(np.float32(v)) for v in (0.0, 0.0, -1.8674267530441284)]
    assert position["max"] == [float(np.float32(v)) for v in (1.0, 1.0, 0.123456789)]
