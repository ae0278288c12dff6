"""The 3D Tiles export's vectorised parts, on small hand-made inputs: exact values, and the same results as
the plain ways they replace."""
from __future__ import annotations

import numpy as np
import shapely
from osgeo import ogr

from wit_plugin.infra.texcoords import aligned_decimals, parse_texcoord_column, unique_texts
from wit_plugin.tiles3d.building_parts import ring_texcoords
from wit_plugin.tiles3d.store import _ground_faces


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
    assert aligned_decimals(_chars(["0.25 0.75", "0.25"])) is None  # a row with fewer numbers
    assert aligned_decimals(_chars(["0.25", "0.25 0.75"])) is None  # a row with more
    assert aligned_decimals(_chars(["0.25 0.75", "0.25_0.75"])) is None  # no blank between two numbers
    assert aligned_decimals(_chars(["0.25 0.75", "0.2a 0.75"])) is None  # a letter among the digits
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
    textured, uv = ring_texcoords(rows, np.array([4, 3, 3, 3]))  # the third row has 2 pairs for 3 ring points
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


def _store_with_buildings(tmp_path, count: int):
    """A staging store holding ``count`` buildings (leaf k, size 10 + k), each with a roof and a wall face written
    wall first (face ids in the LoD1 layer's order), the roofs textured."""
    from wit_plugin.tiles3d.store import FACE_KINDS, Store

    store = Store(tmp_path / "stage.sqlite")
    roof = shapely.to_wkb(shapely.Polygon([(0, 0, 5), (4, 0, 5), (4, 3, 5)]))
    wall = shapely.to_wkb(shapely.Polygon([(0, 0, 0), (4, 0, 0), (4, 0, 5), (0, 0, 5)]))
    for k in range(count):
        store.db.execute("INSERT INTO building VALUES (?, ?, ?, ?, ?)", (f"B{k}", k, 10.0 + k, 0.0, f'["b{k}"]'))
        store.db.execute("INSERT INTO face VALUES (?, ?, ?, ?, ?)", (2 * k, f"B{k}", 1, FACE_KINDS["wall"], wall))
        store.db.execute("INSERT INTO face VALUES (?, ?, ?, ?, ?)", (2 * k + 1, f"B{k}", 2, FACE_KINDS["roof"], roof))
        store.db.execute("INSERT INTO tex_face VALUES (?, ?, ?, ?)",
                         (f"B{k}", 2, k, np.arange(6, dtype=np.float32).tobytes()))
    store.db.execute("CREATE INDEX face_building ON face (wit_id)")
    return store


def test_a_coarse_tile_takes_the_buildings_its_leaves_read(tmp_path):
    """Each building is read (attributes, faces, texture rows) once: the coarse tiles above its leaf draw it again
    from what was parsed; faces come in the LoD1 layer's order."""
    store = _store_with_buildings(tmp_path, 6)
    face_reads = []
    store.db.set_trace_callback(lambda sql: face_reads.append(sql) if "FROM face" in sql else None)
    leaves = [store.buildings(k, k + 1) for k in range(6)]
    assert [rows.ids for rows in leaves] == [[f"B{k}"] for k in range(6)] and len(face_reads) == 6
    coarse = store.buildings(0, 6, min_size=12.0, limit=3)
    assert len(face_reads) == 6  # nothing read again
    assert coarse.ids == ["B5", "B4", "B3"] and coarse.attributes == [["b5"], ["b4"], ["b3"]]
    assert coarse.face_building.tolist() == [0, 0, 1, 1, 2, 2]
    assert coarse.face_kind.tolist() == [1, 0] * 3  # wall, then roof: their order in the layer
    assert coarse.face_image.tolist() == [-1, 5, -1, 4, -1, 3]
    assert coarse.face_uv[0] is None and coarse.face_uv[1].tolist() == [[0, 1], [2, 3], [4, 5]]
    assert [p.wkb for p in coarse.polygons] == [p.wkb for p in leaves[5].polygons] + \
        [p.wkb for p in leaves[4].polygons] + [p.wkb for p in leaves[3].polygons]


def test_the_parsed_buildings_kept_are_bounded(tmp_path, monkeypatch):
    """Memory does not grow with the model: beyond PARSED_BUILDINGS the least recently drawn are dropped (and read
    again when a tile needs them)."""
    from wit_plugin.tiles3d import store as store_module

    monkeypatch.setattr(store_module, "PARSED_BUILDINGS", 2)
    store = _store_with_buildings(tmp_path, 5)
    for k in range(5):
        store.buildings(k, k + 1)
    assert list(store._parsed) == ["B3", "B4"]
    assert store.buildings(0, 5).ids == ["B4", "B3", "B2", "B1", "B0"] and len(store._parsed) == 5  # a tile's own
    store.buildings(0, 1)
    assert list(store._parsed) == ["B1", "B0"]


def _fields(parts) -> dict:
    return {name: value.tolist() for name, value in vars(parts).items()}


def test_a_buildings_parts_are_made_once_and_are_what_a_tile_would_make(tmp_path, monkeypatch):
    """A coarse tile draws its buildings' roofs and walls as made for their leaves (not made again): the same
    arrays, bit for bit, as made for that tile at once; each building's indices moved past those before it."""
    from wit_plugin.tiles3d.building_parts import BuildingParts
    from wit_plugin.tiles3d.geo import Georeference

    store = _store_with_buildings(tmp_path, 6)
    georef = Georeference("EPSG:5186")
    parts = BuildingParts(georef)
    made = []
    original = BuildingParts._made
    monkeypatch.setattr(BuildingParts, "_made", lambda self, rows, ks: made.append(len(ks)) or original(self, rows, ks))
    for k in range(6):
        parts.of(store.buildings(k, k + 1))
    coarse = store.buildings(0, 6, min_size=12.0, limit=3)
    kept = parts.of(coarse)
    assert made == [1] * 6
    fresh = BuildingParts(georef).of(coarse)
    assert made == [1] * 6 + [3] and _fields(kept) == _fields(fresh)
    assert kept.roof_feature.tolist() == [0, 1, 2] and kept.roof_image.tolist() == [-1] * 3  # 3 pairs, 4 points
    assert kept.fan.tolist() == [[0, 1, 2], [0, 2, 3], [5, 6, 7], [5, 7, 8], [10, 11, 12], [10, 12, 13]]
    assert kept.fan_feature.tolist() == [0, 0, 1, 1, 2, 2] and kept.fan_image.tolist() == [-1] * 6
    assert len(set(kept.fan_wall.tolist())) == 3  # a wall apiece: each its own normal
    assert np.array_equal(kept.roof_ecef.reshape(-1, 3), georef.ecef(kept.roof_xyz.reshape(-1, 3)))
    assert kept.roof_uv[0].tolist() == [[0.0, 1.0]] * 3  # (no row that fits: 0, v turned down: 1 - v)


def test_the_buildings_parts_kept_are_bounded(tmp_path, monkeypatch):
    """As the parsed buildings: beyond PARSED_BUILDINGS the least recently drawn are dropped, and made again (the
    same) when a tile needs them."""
    from wit_plugin.tiles3d import store as store_module
    from wit_plugin.tiles3d.building_parts import BuildingParts
    from wit_plugin.tiles3d.geo import Georeference

    monkeypatch.setattr(store_module, "PARSED_BUILDINGS", 2)
    store = _store_with_buildings(tmp_path, 5)
    parts = BuildingParts(Georeference("EPSG:5186"))
    first = [_fields(parts.of(store.buildings(k, k + 1))) for k in range(5)]
    assert list(parts._kept) == ["B3", "B4"]
    assert _fields(parts.of(store.buildings(0, 1))) == first[0] and list(parts._kept) == ["B4", "B0"]


def test_the_colours_filled_within_reach_are_gdals_fill_of_the_whole_image():
    """The coarse terrain fills only the window of the holes near a hit (plus the fill's reach): the same colours as
    GDAL's fill of the whole image, for holes along a seam, in a corner, scattered, and a leaf mostly empty."""
    from wit_plugin.infra.io.raster_io import fill_nodata
    from wit_plugin.tiles3d.coarse import FILL_TEXELS, fill_colours, mem_raster

    def whole(rgb: np.ndarray, hit: np.ndarray) -> np.ndarray:
        mask, bands = mem_raster(hit.astype(np.uint8)[None]), mem_raster(np.moveaxis(rgb, -1, 0))
        for band in range(3):
            fill_nodata(bands.GetRasterBand(band + 1), mask.GetRasterBand(1), FILL_TEXELS)
        return np.moveaxis(bands.ReadAsArray(), 0, -1)

    rng = np.random.default_rng(7)
    cases = []
    for n, blocks, speckle in ((96, 1, False), (96, 3, True), (128, 6, False), (64, 2, True), (120, 1, True)):
        hit = np.zeros((n, n), dtype=bool)
        for _ in range(blocks):
            r, c = rng.integers(0, n, 2)
            h, w = rng.integers(1, n // 2 + 2, 2)
            hit[r:r + h, c:c + w] = True
        if speckle:
            hit &= rng.random((n, n)) < 0.97
        cases.append(hit)
    seam = np.ones((96, 96), dtype=bool)
    seam[:, 90:] = False  # a leaf inside: a strip along its edge
    corner = np.zeros((96, 96), dtype=bool)
    corner[:5, :7] = True  # at the model's edge: almost all holes, most beyond reach
    cases += [seam, corner]
    for hit in cases:
        rgb = rng.integers(0, 256, (*hit.shape, 3), dtype=np.uint8)
        rgb[~hit] = 128
        filled = fill_colours(rgb.copy(), hit)
        assert np.array_equal(filled, whole(rgb, hit))
        assert (filled[hit] == rgb[hit]).all() and (filled != 128).any(axis=2).sum() > hit.sum()
    assert (fill_colours(rgb, np.ones_like(hit)) == rgb).all()


def test_each_images_mip_level_is_the_one_nearest_the_texel_size_asked_for():
    """A 1 m triangle grid on a 256-texel image spanning 64 m (0.25 m texels) and on a 64-texel image spanning 64 m
    (1 m texels): for 1 m texels wanted, levels 2 and 0; for 4 m, levels 4 and 2; an image whose texture rows are
    all degenerate, level 0."""
    from wit_plugin.tiles3d.coarse import _mip_levels
    from wit_plugin.tiles3d.store import TriangleRows

    corners = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0], [0, 1, 0]]], dtype=float)
    xyz = np.concatenate([corners + [x, y, 0] for x in range(64) for y in range(64)])
    uv = (xyz[:, :, :2] / 64).astype(np.float32)
    half = len(xyz) // 2
    image = np.repeat([3, 5], half)
    uv[-2:] = 0.5  # two degenerate texture rows of image 5: left out of its median
    rows = TriangleRows(xyz, np.zeros(len(xyz), dtype=np.int8), image, uv, np.zeros(len(xyz), dtype=np.int64))
    shapes = {3: (256, 256), 5: (64, 64)}
    assert _mip_levels(rows, shapes, 1.0) == {3: 2, 5: 0}
    assert _mip_levels(rows, shapes, 4.0) == {3: 4, 5: 2}
    assert _mip_levels(rows, {}, 1.0) == {}
    flat = TriangleRows(xyz[:4], np.zeros(4, dtype=np.int8), np.full(4, 7), np.zeros((4, 3, 2), dtype=np.float32),
                        np.zeros(4, dtype=np.int64))
    assert _mip_levels(flat, {7: (64, 64)}, 8.0) == {7: 0}


def test_decimal_integers_are_what_numpy_parses():
    """The texture table's triangle ids, parsed column by column: the values of ``astype(np.int64)`` for digits of any
    length in a wider column (a building's id beside them), and numpy's own answer, or error, for anything else."""
    from wit_plugin.infra.texcoords import decimal_integers

    rng = np.random.default_rng(11)
    ids = np.concatenate([[0, 7, 10, 999_999_999_999_999_999], rng.integers(0, 10 ** rng.integers(1, 18, 500))])
    texts = np.array([str(v).encode() for v in ids] + [b"BLD_1168011500008130002000001"])[:-1]  # (a wide column)
    assert texts.dtype.itemsize == 29
    assert decimal_integers(texts).tolist() == ids.tolist()
    assert decimal_integers(np.array([b"0012", b"3"])).tolist() == [12, 3]  # leading zeros
    for odd in ([b"-5", b"12"], [b" 7", b"8"], [b"1234567890123456789", b"1"]):  # numpy's parse: the same values
        assert decimal_integers(np.array(odd)).tolist() == np.array(odd).astype(np.int64).tolist()
    for bad in ([b"12", b"1a"], [b"", b"3"], [b"12", b"3 4"]):
        try:
            decimal_integers(np.array(bad))
        except ValueError:
            pass
        else:
            raise AssertionError(f"{bad} was taken as numbers")
    assert decimal_integers(np.array([5, 6])).tolist() == [5, 6]


def test_a_triangles_texture_row_is_the_last_written_for_its_id(tmp_path):
    """The texture blocks of several batches of the texture table, over two id buckets, an id written again by a later
    batch: each triangle gets the row the table wrote last for it (what a search block by block gave), an id without
    a row none, whatever the order the TIN gives its ids in."""
    from wit_plugin.tiles3d.store import TEX_BUCKET, Store

    store = Store(tmp_path / "stage.sqlite")
    rng = np.random.default_rng(4)
    written: dict[int, tuple[int, list[float]]] = {}
    for _batch in range(3):
        ids = np.sort(rng.choice(np.arange(2 * TEX_BUCKET - 50, 2 * TEX_BUCKET + 50), 40, replace=False))
        image = rng.integers(0, 9, len(ids))
        uv = rng.random((len(ids), 3, 2)).astype(np.float32)
        bucket = ids // TEX_BUCKET
        for b in np.unique(bucket):
            mine = bucket == b
            store.db.execute("INSERT INTO tex_block VALUES (?, ?, ?, ?, ?)", (
                int(ids[mine][0]), int(ids[mine][-1]), ids[mine].tobytes(), image[mine].tobytes(), uv[mine].tobytes()))
        for k, i in enumerate(ids.tolist()):
            written[i] = (int(image[k]), uv[k].ravel().tolist())
    wanted = rng.permutation(np.arange(2 * TEX_BUCKET - 60, 2 * TEX_BUCKET + 60))
    image, uv = store._triangle_textures(wanted)
    for k, i in enumerate(wanted.tolist()):
        expected = written.get(i, (-1, [0.0] * 6))
        assert (int(image[k]), uv[k].ravel().tolist()) == expected, i
    assert 0 < (image >= 0).sum() < len(wanted)
    store.close()
