"""The 3D Tiles export's vectorised parts, on small hand-made inputs: exact values, and the same results as
the plain ways they replace."""
from __future__ import annotations

import numpy as np
from osgeo import ogr

from wit_plugin.infra.texcoords import aligned_decimals, parse_texcoord_column, unique_texts
from wit_plugin.tiles3d.store import _ground_faces
from wit_plugin.tiles3d.tileset import _ring_uv


def _chars(rows: list[str]) -> np.ndarray:
    """Rows as Arrow gives a text column (fixed-width bytes), in the (rows, width + 1) block ``_texcoords`` builds."""
    values = np.array([r.encode() for r in rows])
    chars = np.full((len(values), values.dtype.itemsize + 1), 32, dtype=np.uint8)
    chars[:, :-1] = np.frombuffer(values.tobytes(), dtype=np.uint8).reshape(len(values), -1)
    return chars


def test_aligned_decimals_are_the_correctly_rounded_values_of_the_texts():
    rng = np.random.default_rng(5)
    values = np.concatenate([rng.random(4000), rng.random(1000) * 9.9, [0.0, 1.0, 0.5, 9.999999999999]])
    texts = [f"{u:.12f}" for u in values]
    rows = [" ".join(texts[i:i + 8]) for i in range(0, 4000, 8)]
    numbers = aligned_decimals(_chars(rows))
    assert numbers.tolist() == [float(t) for t in texts[:4000]]  # float(): Python's correctly rounded parse
    hard = ["0.100000000000 0.300000000000", "0.000000000001 0.999999999999", "0.123456789012 0.987654321098"]
    assert aligned_decimals(_chars(hard)).tolist() == [0.1, 0.3, 1e-12, 0.999999999999, 0.123456789012,
                                                       0.987654321098]
    assert aligned_decimals(_chars(["12.5 10.25"])) is None  # numbers of two widths
    assert aligned_decimals(_chars(["2.50 1.25", "12.5 3.75"])) is None  # another row's columns
    assert aligned_decimals(_chars(["0.5 -0.5"])) is None  # a sign
    assert aligned_decimals(_chars(["1e-3 2e-3"])) is None  # an exponent
    assert aligned_decimals(_chars(["1234567890.1234567 0.0000000000000001"])) is None  # 17 digits


def test_texcoords_of_any_rows_are_those_of_the_plain_parse():
    """Rows the aligned parse does not take (roofs' rings of several lengths, other forms) give the same pairs
    and counts through C's parser; an odd count of numbers is refused."""
    aligned = ["0.250000000000 0.750000000000 0.500000000000 0.125000000000"] * 3
    mixed = ["0.1 0.2 0.3 0.4 0.1 0.2", "", "1 2", "-0.5 1e-1"]
    for rows in (aligned, mixed):
        uv, counts = parse_texcoord_column(np.array([r.encode() for r in rows]))
        numbers = [float(t) for r in rows for t in r.split()]
        assert uv.ravel().tolist() == numbers and counts.tolist() == [len(r.split()) // 2 for r in rows]
    try:
        parse_texcoord_column(np.array([b"0.1 0.2 0.3"]))
    except ValueError:
        pass
    else:
        raise AssertionError("an odd count of numbers was taken")


def _faces_layer(path, date: bool):
    """A GeoPackage layer of faces: 3D, 2D, with a hole, empty and without geometry; NULLs and Korean text."""
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer("faces", geom_type=ogr.wkbUnknown)
    for name, kind in (("name", ogr.OFTString), ("floors", ogr.OFTInteger), ("serial", ogr.OFTInteger64),
                       ("height", ogr.OFTReal)) + ((("built", ogr.OFTDate),) if date else ()):
        layer.CreateField(ogr.FieldDefn(name, kind))
    rows = [("POLYGON Z ((0 0 5,4 0 6,4 3 7,0 0 5))", ("자곡 아파트", 3, 2 ** 40, 9.5)),
            ("POLYGON ((10 10,12 10,12 11,10 10))", (None, None, None, None)),
            ("POLYGON Z ((0 0 9,8 0 9,8 8 9,0 8 9,0 0 9),(2 2 1,3 2 1,3 3 1,2 2 1))", ("", 0, -1, 0.1)),
            ("POLYGON EMPTY", ("empty", 1, 1, 1.0)), (None, ("none", 1, 1, 1.0))]
    for wkt, values in rows:
        feature = ogr.Feature(layer.GetLayerDefn())
        if wkt:
            feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
        for k, value in enumerate(values):
            if value is not None:
                feature.SetField(k, value)
        if date:
            feature.SetField(4, 2024, 5, 17, 0, 0, 0, 0)
        layer.CreateFeature(feature)
    return ds, layer


def test_ground_faces_read_in_columns_give_what_ogr_gives(tmp_path):
    """Plain fields: column batches; with a date field: the feature loop. Both give OGR's envelopes and values."""
    for date in (False, True):
        ds, layer = _faces_layer(tmp_path / f"faces{date}.gpkg", date)
        faces = list(_ground_faces(layer, list(range(layer.GetLayerDefn().GetFieldCount()))))
        expected = [((0.0, 4.0, 0.0, 3.0, 5.0), ["자곡 아파트", 3, 2 ** 40, 9.5]),
                    ((10.0, 12.0, 10.0, 11.0, 0.0), [None, None, None, None]),
                    ((0.0, 8.0, 0.0, 8.0, 1.0), ["", 0, -1, 0.1])]
        assert [(tuple(box), values) for box, values in faces] == [
            (box, values + (["2024/05/17"] if date else [])) for box, values in expected]
        del layer, ds


def test_unique_texts_are_sorted_with_each_rows_index():
    names, index = unique_texts(np.array([b"tin", b"tin", b"road", b"tin", b"road", b"road", b"\xea\xb8\xb8"]))
    assert names == ["road", "tin", "길"] and index.tolist() == [1, 1, 0, 1, 0, 0, 2]
    names, index = unique_texts(np.array(["b", None, "a", "b"], dtype=object))
    assert names == ["", "a", "b"] and index.tolist() == [2, 0, 1, 2]
    names, index = unique_texts(np.array([], dtype="S4"))
    assert names == [] and index.tolist() == []


def test_ring_uv_takes_the_rows_that_fit_their_rings():
    rows = [np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]], dtype=np.float32), None,
            np.array([[0.5, 0.5], [0.25, 0.5]], dtype=np.float32), np.array([[2.0, 3.0]] * 3, dtype=np.float32)]
    textured, uv = _ring_uv(rows, np.array([4, 3, 3, 3]))  # the third row has 2 pairs for 3 ring points
    assert textured.tolist() == [True, False, False, True]
    assert uv.tolist() == [[0, 0], [1, 0], [1, 1], [0, 0]] + [[0, 0]] * 6 + [[2, 3]] * 3


def test_distinct_rows_are_those_of_np_unique_on_the_rows_bytes():
    from wit_plugin.tiles3d.glb import distinct_rows

    rng = np.random.default_rng(3)
    vertices = rng.integers(0, 5, (40, 5)).astype(np.float32) / 4 - 0.5  # few values: -0.0 and 0.0 too
    vertices[:, 0] = np.arange(40) - 20.0  # x, y of each vertex its own
    for clashes in (2, 30):  # rows alike in x, y but not after: a few (sorted apart) or many (np.unique)
        rows = vertices[rng.integers(0, len(vertices), 400)]
        rows[rng.choice(400, clashes, replace=False), 2] = 7.0
        first, index = distinct_rows(rows)
        expected = np.unique(rows.view(np.dtype((np.void, 20))).ravel(), return_index=True, return_inverse=True)
        assert first.tolist() == expected[1].tolist() and index.tolist() == expected[2].ravel().tolist()
