"""wit:wittexture core: UV exactness, table contract, gutters vs mipmaps, mip chain, windowed reads."""
from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from osgeo import gdal, ogr, osr

from wit_plugin import texture
from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.texture import TextureConfig, texture_model
from wit_plugin.texture.images import mip_chain

X0, Y0, PX = 200000.0, 500000.0, 0.5  # ortho origin (top-left) and pixel size, EPSG:5186


def _srs() -> osr.SpatialReference:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    return srs


def make_ortho(path: Path, pixels: np.ndarray | None = None, size: tuple[int, int] | None = None) -> str:
    """A tiled RGB GeoTIFF at (X0, Y0) with PX pixels: ``pixels`` (rows × cols × 3) or empty of ``size``."""
    h, w = pixels.shape[:2] if pixels is not None else size
    ds = gdal.GetDriverByName("GTiff").Create(str(path), w, h, 3, gdal.GDT_Byte,
                                              ["TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256"])
    ds.SetGeoTransform((X0, PX, 0, Y0, 0, -PX))
    ds.SetProjection(_srs().ExportToWkt())
    if pixels is not None:
        for b in range(3):
            ds.GetRasterBand(b + 1).WriteArray(pixels[:, :, b])
    ds = None
    return str(path)


def centre(col: float, row: float) -> tuple[float, float]:
    """Ground coordinates of the centre of ortho pixel (col, row)."""
    return X0 + (col + 0.5) * PX, Y0 - (row + 0.5) * PX


def _polygon(ring: list[tuple[float, float]], z: float) -> ogr.Geometry:
    lr = ogr.Geometry(ogr.wkbLinearRing)
    for x, y in ring + ring[:1]:
        lr.AddPoint(x, y, z)
    poly = ogr.Geometry(ogr.wkbPolygon25D)
    poly.AddGeometry(lr)
    return poly


def write_lod1(path: Path, buildings: dict[str, list[tuple[float, float]]]) -> str:
    """LoD1 faces in the step_layers.py schema: per building one ground, one roof and one wall per edge."""
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(step_layers.LOD1_LAYER, _srs(), ogr.wkbPolygon25D)
    for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                       (step_layers.FACE_NUMBER, ogr.OFTInteger), (step_layers.HEIGHT, ogr.OFTReal)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    for wit_id, ring in buildings.items():
        faces = [("ground", _polygon(ring[::-1], 10.0)), ("roof", _polygon(ring, 20.0))]
        for (xa, ya), (xb, yb) in zip(ring, ring[1:] + ring[:1]):
            wall = ogr.Geometry(ogr.wkbLinearRing)
            for x, y, z in ((xa, ya, 10), (xb, yb, 10), (xb, yb, 20), (xa, ya, 20), (xa, ya, 10)):
                wall.AddPoint(x, y, z)
            poly = ogr.Geometry(ogr.wkbPolygon25D)
            poly.AddGeometry(wall)
            faces.append(("wall", poly))
        for number, (kind, geom) in enumerate(faces):
            f = ogr.Feature(layer.GetLayerDefn())
            f.SetField(step_layers.WIT_ID, wit_id)
            f.SetField(step_layers.FACE_TYPE, kind)
            f.SetField(step_layers.FACE_NUMBER, number)
            f.SetField(step_layers.HEIGHT, 10.0)
            f.SetGeometry(geom)
            layer.CreateFeature(f)
    ds = None
    return str(path)


def write_tin(path: Path, triangles: list[tuple[str, list[tuple[float, float]]]]) -> str:
    """TIN triangles in the step_layers.py schema; tri_id = index; road triangles on road RD_1 but every 7th."""
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(step_layers.TIN_LAYER, _srs(), ogr.wkbPolygon25D)
    for name, kind in ((step_layers.TIN_TRIANGLE_ID, ogr.OFTInteger), (step_layers.TIN_SURFACE, ogr.OFTString),
                       (step_layers.TIN_FEATURE_ID, ogr.OFTString)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    layer.StartTransaction()
    for tri_id, (surface, ring) in enumerate(triangles):
        f = ogr.Feature(layer.GetLayerDefn())
        f.SetField(step_layers.TIN_TRIANGLE_ID, tri_id)
        f.SetField(step_layers.TIN_SURFACE, surface)
        if surface == "road" and tri_id % 7:
            f.SetField(step_layers.TIN_FEATURE_ID, "RD_1")
        f.SetGeometry(_polygon(ring, 30.0))
        layer.CreateFeature(f)
    layer.CommitTransaction()
    ds = None
    return str(path)


def grid_triangles(c0: int, r0: int, c1: int, r1: int, step: int) -> list[tuple[str, list[tuple[float, float]]]]:
    """Two triangles per grid cell, vertices at pixel centres; surfaces cycle terrain/road/footprint."""
    tris = []
    for r in range(r0, r1, step):
        for c in range(c0, c1, step):
            a, b, cc, d = centre(c, r), centre(c + step, r), centre(c + step, r + step), centre(c, r + step)
            for ring in ([a, d, cc], [a, cc, b]):
                tris.append((step_layers.TIN_SURFACES[len(tris) % 3], ring))
    return tris


def read_rows(output: Path) -> list[dict]:
    ds = ogr.Open(str(output / texture.TEXCOORDS_FILE))
    layer = ds.GetLayerByName(step_layers.TEXCOORD_TABLE)
    assert layer.GetGeomType() == ogr.wkbNone
    rows = []
    for f in layer:
        rows.append({"target": f.GetField(step_layers.TEX_TARGET), "feature": f.GetField(step_layers.TEX_FEATURE),
                     "face": f.GetField(step_layers.TEX_FACE), "image": f.GetField(step_layers.TEX_IMAGE),
                     "uv": np.array(f.GetField(step_layers.TEX_COORDS).split(), dtype=float).reshape(-1, 2)})
    ds = None
    with sqlite3.connect(output / texture.TEXCOORDS_FILE) as db:  # the count GDAL keeps matches the rows
        assert db.execute("SELECT feature_count FROM gpkg_ogr_contents WHERE table_name = ?",
                          (step_layers.TEXCOORD_TABLE,)).fetchone() == (len(rows),)
    return rows


def read_image(path: Path) -> np.ndarray:
    return gdal.Open(str(path)).ReadAsArray().transpose(1, 2, 0)


def unique_colours(h: int, w: int, block: int = 1) -> np.ndarray:
    """Ortho whose every block × block square has its own colour (R = block col, G = block row)."""
    rows, cols = np.mgrid[0:h, 0:w] // block
    return np.stack([cols, rows, np.full_like(cols, 77)], axis=-1).astype(np.uint8)


# L-shaped and rectangular roofs, vertices at pixel centres (col, row)
ROOFS = {
    "BLD_A": [(10, 10), (30, 10), (30, 25), (20, 25), (20, 40), (10, 40)],
    "BLD_B": [(60, 12), (95, 12), (95, 30), (60, 30)],
    "BLD_C": [(120, 90), (131, 90), (131, 140), (120, 140)],
    "BLD_D": [(150, 5), (190, 5), (190, 60), (150, 60)],
}


@pytest.fixture
def scene(tmp_path: Path) -> dict:
    """200 × 150 px ortho of unique colours; four buildings; a TIN of 2262 triangles over the ortho."""
    pixels = unique_colours(150, 200)
    ortho = make_ortho(tmp_path / "ortho.tif", pixels)
    lod1 = write_lod1(tmp_path / "lod1.gpkg", {k: [centre(c, r) for c, r in v] for k, v in ROOFS.items()})
    tris = grid_triangles(2, 2, 197, 147, 5)
    tin = write_tin(tmp_path / "tin.gpkg", tris)
    return {"pixels": pixels, "ortho": ortho, "lod1": lod1, "tin": tin, "triangles": tris}


def _expected_rings(triangles: list) -> dict[tuple[str, str], list]:
    """(target, feature) -> ring points (closing point included) of every surface that must be textured."""
    rings = {("roof", k): [centre(c, r) for c, r in v + v[:1]] for k, v in ROOFS.items()}
    for tri_id, (surface, ring) in enumerate(triangles):
        if surface != "footprint":
            target = "road" if surface == "road" and tri_id % 7 else "tin"  # a road triangle off any road: relief
            rings[(target, str(tri_id))] = ring + ring[:1]
    return rings


def test_uv_hits_pixel_centres_exactly_at_full_scale(scene: dict, tmp_path: Path) -> None:
    out = tmp_path / "tex"
    config = TextureConfig(image_format="PNG", atlas_size=128, gutter=4, facades="none")
    report = texture_model(scene["ortho"], scene["lod1"], scene["tin"], str(out), config)
    assert report.downscaled == 0
    rows = read_rows(out)
    expected = _expected_rings(scene["triangles"])
    assert {(r["target"], r["feature"]) for r in rows} == set(expected)  # no walls, ground faces, footprints
    assert len(rows) == len(expected)
    targets = [target for target, _ in expected]
    assert report.surfaces == {t: targets.count(t) for t in ("roof", "wall", "tin", "road")}
    assert 0 < targets.count("road") < sum(s == "road" for s, _ in scene["triangles"])
    assert report.untextured == {"wall": 4 + 4 + 4 + 6, "ground": 4,
                                 "footprint": sum(s == "footprint" for s, _ in scene["triangles"])}
    assert report.atlases == 1 and report.ground_images == 4  # 128 px images: 112 px (56 m) ground squares
    assert len(report.images) == report.atlases + report.ground_images
    images = {}
    for row in rows:
        if row["target"] == "roof":
            assert row["face"] == 1  # the roof's FACE_NUMBER in write_lod1
        else:
            assert row["face"] is None
        ring = expected[(row["target"], row["feature"])]
        assert row["uv"].shape == (len(ring), 2)  # one pair per ring point, closing point included
        if row["image"] not in images:
            images[row["image"]] = read_image(out / row["image"])
        img = images[row["image"]]
        h, w = img.shape[:2]
        for (x, y), (u, v) in zip(ring, row["uv"]):
            tx, ty = u * w, (1.0 - v) * h
            assert tx - math.floor(tx) == pytest.approx(0.5, abs=1e-9)
            assert ty - math.floor(ty) == pytest.approx(0.5, abs=1e-9)
            col, row_ = round((x - X0) / PX - 0.5), round((Y0 - y) / PX - 0.5)
            assert tuple(img[math.floor(ty), math.floor(tx)]) == tuple(scene["pixels"][row_, col])
    assert report.texel_size == PX and report.texels_per_m2 == pytest.approx(4.0)
    assert report.bytes_written == sum(p.stat().st_size for p in out.iterdir())


def test_half_scale_averages_pixel_blocks(tmp_path: Path) -> None:
    pixels = unique_colours(150, 200, block=2)
    ortho = make_ortho(tmp_path / "ortho.tif", pixels)
    lod1 = write_lod1(tmp_path / "lod1.gpkg", {k: [centre(c, r) for c, r in v] for k, v in ROOFS.items()})
    triangles = grid_triangles(1, 1, 196, 146, 5)
    tin = write_tin(tmp_path / "tin.gpkg", triangles)
    out = tmp_path / "tex"
    report = texture_model(ortho, lod1, tin, str(out), TextureConfig(scale=0.5, image_format="PNG", atlas_size=64,
                                                                     facades="none"))
    assert report.texel_size == 2 * PX and report.downscaled == 0
    rows = read_rows(out)
    expected = _expected_rings(triangles)
    assert len(rows) == len(expected)
    images, fractions = {}, set()
    for row in rows:
        if row["image"] not in images:
            images[row["image"]] = read_image(out / row["image"])
        img = images[row["image"]]
        h, w = img.shape[:2]
        for (x, y), (u, v) in zip(expected[(row["target"], row["feature"])], row["uv"]):
            tx, ty = u * w, (1.0 - v) * h
            fx, fy = tx - math.floor(tx), ty - math.floor(ty)
            # a pixel centre lies a quarter texel off the centre of its 2 × 2 block's texel
            assert min(abs(fx - 0.25), abs(fx - 0.75)) < 1e-9 and min(abs(fy - 0.25), abs(fy - 0.75)) < 1e-9
            fractions.add(round(fx, 2))
            col, row_ = round((x - X0) / PX - 0.5), round((Y0 - y) / PX - 0.5)
            assert tuple(img[math.floor(ty), math.floor(tx)]) == tuple(pixels[row_, col])
    assert fractions == {0.25, 0.75}


def test_every_image_exists_jpeg_default(scene: dict, tmp_path: Path) -> None:
    """Images cut from the ortho are JPEG by default; the generated facades are PNG (flat colours, lossless)."""
    out = tmp_path / "tex"
    report = texture_model(scene["ortho"], scene["lod1"], scene["tin"], str(out))
    names = {r["image"] for r in read_rows(out)}
    assert names == set(report.images) and all((out / n).is_file() for n in names)
    facades = {n for n in names if n.startswith("facade_")}
    assert facades and all(n.endswith(".png") for n in facades)
    assert all(n.endswith(".jpg") for n in names - facades)
    assert sorted(p.name for p in out.iterdir()) == sorted(names | {texture.TEXCOORDS_FILE, step_layers.FACADE_FILE})
    assert report.atlases == 1  # four small roofs fit one 2048 atlas, cropped to powers of two
    h, w = read_image(out / report.images[0]).shape[:2]
    assert h < 2048 and w < 2048 and h & (h - 1) == 0 and w & (w - 1) == 0


def test_gutters_keep_islands_apart_down_to_the_gutter_mip_level(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    pixels = np.full((300, 300, 3), 100, np.uint8)
    roofs, colours = {}, {}
    for i in range(24):  # pure-colour roofs of various sizes on a grey ground, one pixel bbox each
        c, r = 5 + (i % 6) * 48, 5 + (i // 6) * 70
        w, h = int(rng.integers(3, 40)), int(rng.integers(3, 60))
        colours[f"B{i}"] = (int(rng.integers(0, 256)), int(rng.integers(0, 256)), i * 10)
        pixels[r:r + h, c:c + w] = colours[f"B{i}"]
        roofs[f"B{i}"] = [centre(c, r), centre(c + w - 1, r), centre(c + w - 1, r + h - 1), centre(c, r + h - 1)]
    ortho = make_ortho(tmp_path / "ortho.tif", pixels)
    lod1 = write_lod1(tmp_path / "lod1.gpkg", roofs)
    out = tmp_path / "tex"
    gutter = 4
    config = TextureConfig(image_format="PNG", atlas_size=128, gutter=gutter, facades="none")
    report = texture_model(ortho, lod1, None, str(out), config)
    assert report.atlases >= 2
    by_image: dict[str, list] = {}
    for row in read_rows(out):
        by_image.setdefault(row["image"], []).append(row)
    level = int(math.log2(gutter))  # the gutter shrinks to one texel here
    bled_deeper = False
    for name, rows in by_image.items():
        chain = mip_chain(read_image(out / name))
        for k in (level, level + 2):
            img = chain[k]
            h0, w0 = chain[0].shape[:2]
            for row in rows:
                tx, ty = row["uv"][:, 0] * w0, (1.0 - row["uv"][:, 1]) * h0
                x0, x1 = int(tx.min()) >> k, int(tx.max()) >> k
                y0, y1 = int(ty.min()) >> k, int(ty.max()) >> k
                under = img[y0:y1 + 1, x0:x1 + 1].reshape(-1, 3)
                clean = bool((under == colours[row["feature"]]).all())
                if k == level:
                    assert clean, f"{row['feature']} bleeds at mip level {k} in {name}"
                else:
                    bled_deeper |= not clean
    assert bled_deeper  # the check does see bleeding where the gutter is too thin


def test_mip_chain_sizes_and_box_filter() -> None:
    chain = mip_chain(np.random.default_rng(1).integers(0, 256, (1024, 1024, 3), dtype=np.uint8))
    assert [lvl.shape for lvl in chain] == [(1024 >> k, 1024 >> k, 3) for k in range(11)]  # paper Table 10
    assert all(lvl.dtype == np.uint8 for lvl in chain)
    assert np.abs(chain[-1].astype(float) - chain[0].reshape(-1, 3).mean(axis=0)).max() <= 0.5
    img = np.random.default_rng(2).random((300, 1000))
    chain = mip_chain(img)
    assert [lvl.shape for lvl in chain] == [(300, 1000), (150, 500), (75, 250), (37, 125), (18, 62), (9, 31),
                                            (4, 15), (2, 7), (1, 3), (1, 1)]
    for lvl in chain:  # area-weighted: every level keeps the mean
        assert lvl.mean() == pytest.approx(img.mean(), abs=1e-12)
    row = np.array([[0.0, 0.0, 0.0, 0.0, 10.0]])  # 5 → 2: [0, 2.5) and [2.5, 5)
    assert mip_chain(row)[1].tolist() == [[0.0, 4.0]]
    assert mip_chain(np.array([[7]], dtype=np.uint8))[0].tolist() == [[7]]


def test_mipmap_files_written(scene: dict, tmp_path: Path) -> None:
    out = tmp_path / "tex"
    report = texture_model(scene["ortho"], scene["lod1"], None, str(out),
                           TextureConfig(image_format="PNG", write_mipmaps=True, facades="none"))
    stem = Path(report.images[0]).stem
    base = read_image(out / report.images[0])
    n = max(base.shape[:2]).bit_length() - 1
    assert report.mip_files == n
    for k in range(1, n + 1):
        level = read_image(out / f"{stem}_mip{k}.png")
        assert level.shape[:2] == (max(1, base.shape[0] >> k), max(1, base.shape[1] >> k))
    assert not (out / f"{stem}_mip{n + 1}.png").exists()


def test_ortho_is_read_in_windows(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ortho = make_ortho(tmp_path / "big.tif", size=(6000, 6000))  # 108 MB of RGB if read whole
    roofs = {f"B{i}": [centre(c, r), centre(c + 30, r), centre(c + 30, r + 20), centre(c, r + 20)]
             for i, (c, r) in enumerate((c, r) for c in range(100, 5900, 700) for r in range(100, 5900, 900))}
    lod1 = write_lod1(tmp_path / "lod1.gpkg", roofs)
    tin = write_tin(tmp_path / "tin.gpkg", grid_triangles(500, 500, 2000, 2000, 20))
    reads = []
    original = gdal.Dataset.ReadAsArray

    def spy(self, xoff=0, yoff=0, xsize=None, ysize=None, *args, **kwargs):
        reads.append((xsize, ysize))
        return original(self, xoff, yoff, xsize, ysize, *args, **kwargs)

    monkeypatch.setattr(gdal.Dataset, "ReadAsArray", spy)
    monkeypatch.setattr(gdal.Band, "ReadAsArray", lambda *a, **k: pytest.fail("band-wise whole reads"))
    report = texture_model(ortho, lod1, tin, str(tmp_path / "tex"), TextureConfig(atlas_size=256))
    assert report.downscaled == 0 and report.surfaces["roof"] == len(roofs) and report.ground_images == 49
    assert len(reads) == len(roofs) + report.ground_images
    assert all(w is not None and h is not None and w <= 256 and h <= 256 for w, h in reads)  # ≤ one atlas


def test_triangles_on_ground_square_borders_come_once(scene: dict, tmp_path: Path) -> None:
    side = math.floor(64 * 0.875) * PX  # ground square side for 64 px images: 28 m
    lines = [k * side / 2 for k in range(6)]  # every other line is a tile border; 70 m < the ortho's 75 m
    tris = []
    for i in range(5):
        for j in range(5):
            a, b = (X0 + lines[i], Y0 - lines[j]), (X0 + lines[i + 1], Y0 - lines[j])
            c, d = (X0 + lines[i + 1], Y0 - lines[j + 1]), (X0 + lines[i], Y0 - lines[j + 1])
            tris += [("road", [a, d, c]), ("terrain", [c, b, a])]  # first vertex on a border corner or not
    tin = write_tin(tmp_path / "borders.gpkg", tris)
    out = tmp_path / "tex"
    report = texture_model(scene["ortho"], None, tin, str(out), TextureConfig(atlas_size=64, gutter=2))
    rows = read_rows(out)
    assert sorted(int(r["feature"]) for r in rows) == list(range(len(tris)))
    assert report.ground_images == 9
    for row in rows:
        assert (row["uv"] >= 0).all() and (row["uv"] <= 1).all()


class _CancelAfter(Feedback):
    def __init__(self, calls: int):
        self.calls = calls

    def progress(self, percent: float) -> None:
        self.calls -= 1

    def is_canceled(self) -> bool:
        return self.calls <= 0


def test_cancel_leaves_no_output(scene: dict, tmp_path: Path) -> None:
    out = tmp_path / "tex"
    with pytest.raises(CanceledError):
        texture_model(scene["ortho"], scene["lod1"], scene["tin"], str(out),
                      TextureConfig(atlas_size=64), feedback=_CancelAfter(3))
    assert not out.exists()  # the folder made for this run is removed too


def test_surface_outside_the_ortho_is_refused(scene: dict, tmp_path: Path) -> None:
    lod1 = write_lod1(tmp_path / "far.gpkg", {"BLD_FAR": [centre(190, 10), centre(230, 10), centre(230, 30)]})
    out = tmp_path / "tex"
    with pytest.raises(InputError, match="beyond the orthoimage"):
        texture_model(scene["ortho"], lod1, scene["tin"], str(out))
    assert not out.exists() or list(out.iterdir()) == []


@pytest.mark.parametrize("config, message", [
    (TextureConfig(scale=0.0), "0 < S"), (TextureConfig(scale=1.5), "0 < S"),
    (TextureConfig(image_format="WEBP"), "not supported"), (TextureConfig(atlas_size=1000), "power of two"),
    (TextureConfig(gutter=-1), "Gutter"), (TextureConfig(jpeg_quality=0), "quality"),
])
def test_bad_parameters(scene: dict, tmp_path: Path, config: TextureConfig, message: str) -> None:
    with pytest.raises(InputError, match=message):
        texture_model(scene["ortho"], scene["lod1"], scene["tin"], str(tmp_path / "tex"), config)


def test_bad_inputs(scene: dict, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="nothing to texture"):
        texture_model(scene["ortho"], None, None, str(tmp_path / "tex"))
    with pytest.raises(InputError, match=r"Layer 'tin' in .* lacks the field\(s\) wit_id, wit_face, wit_face_no of the "
                                         r"LoD1 faces \(wit:extrudebuildings\)"):
        texture_model(scene["ortho"], scene["tin"], None, str(tmp_path / "tex"))
    with pytest.raises(InputError, match="orthoimage .*missing.tif does not exist"):
        texture_model(str(tmp_path / "missing.tif"), scene["lod1"], None, str(tmp_path / "tex"))


def test_surfaces_outside_the_coverage_are_left_untextured_and_counted(tmp_path):
    """With a coverage (the ortho's sheets), what lies beyond it is counted, not refused."""
    import shapely

    ortho = make_ortho(tmp_path / "ortho.tif", size=(200, 200))
    inside = [centre(20, 20), centre(40, 20), centre(40, 40), centre(20, 40)]
    beyond = [(X0 + 150, Y0 - 20), (X0 + 170, Y0 - 20), (X0 + 170, Y0 - 40), (X0 + 150, Y0 - 40)]  # east of the ortho
    lod1 = write_lod1(tmp_path / "lod1.gpkg", {"BLD_IN": inside, "BLD_OUT": beyond})
    with pytest.raises(InputError, match="reaches beyond the orthoimage"):
        texture_model(ortho, lod1, None, str(tmp_path / "refused"))
    coverage = shapely.box(X0, Y0 - 100, X0 + 100, Y0)  # the ortho: 200 px of 0.5 m
    report = texture_model(ortho, lod1, None, str(tmp_path / "tex"), coverage=coverage)
    assert report.surfaces[texture.ROOF_TARGET] == 1 and report.untextured[texture.BEYOND_ORTHO] == 1
    rows = sqlite3.connect(tmp_path / "tex" / step_layers.TEXCOORD_FILE).execute(
        f"SELECT {step_layers.TEX_TARGET}, {step_layers.TEX_FEATURE} FROM {step_layers.TEXCOORD_TABLE}").fetchall()
    # generated facades need no orthoimage: both buildings' walls have theirs
    assert sorted(set(rows)) == [("roof", "BLD_IN"), ("wall", "BLD_IN"), ("wall", "BLD_OUT")]
    assert report.surfaces[texture.WALL_TARGET] == 8


def test_layers_read_in_several_runs_give_the_same_output(scene: dict, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Tiles whose points do not fit in memory together are read in runs: the output does not change."""
    def run(name: str) -> tuple[list, dict]:
        out = tmp_path / name
        texture_model(scene["ortho"], scene["lod1"], scene["tin"], str(out), TextureConfig(atlas_size=64, gutter=2))
        with sqlite3.connect(out / texture.TEXCOORDS_FILE) as db:
            rows = db.execute(f'SELECT * FROM "{step_layers.TEXCOORD_TABLE}" ORDER BY fid').fetchall()
        return rows, {p.name: p.read_bytes() for p in out.iterdir() if p.suffix in (".jpg", ".png")}

    whole = run("whole")
    monkeypatch.setattr(texture.sources, "_POINTS_IN_MEMORY", 500)  # ~125 triangles: one tile at a time
    assert run("runs") == whole
    walls = 4 + 4 + 4 + 6
    assert len(whole[0]) == 4 + walls + sum(s != "footprint" for s, _ in scene["triangles"]) and len(whole[1]) > 9


def test_a_face_that_is_not_a_polygon_is_refused(scene: dict, tmp_path: Path) -> None:
    tin = write_tin(tmp_path / "points.gpkg", [("terrain", [centre(5, 5), centre(9, 5), centre(5, 9)])] * 3)
    ds = ogr.Open(tin, 1)
    layer = ds.GetLayer(0)
    feature = layer.GetFeature(2)
    feature.SetGeometry(ogr.CreateGeometryFromWkt("POINT Z (200003 499997 30)"))
    layer.SetFeature(feature)
    ds = None
    out = tmp_path / "tex"
    with pytest.raises(InputError, match="Feature 2 of layer 'tin' .* is a POINT, not a polygon face"):
        texture_model(scene["ortho"], None, tin, str(out))
    assert not out.exists() or list(out.iterdir()) == []


def test_no_garbage_collection_during_the_step(scene: dict, tmp_path: Path) -> None:
    """The step makes millions of short-lived objects and no cycles: the collector is paused, then back."""
    import gc

    class Spy(Feedback):
        seen: set = set()

        def is_canceled(self) -> bool:  # asked between tiles
            self.seen.add(gc.isenabled())
            return False

    texture_model(scene["ortho"], scene["lod1"], scene["tin"], str(tmp_path / "tex"), TextureConfig(atlas_size=64),
                  feedback=Spy())
    assert Spy.seen == {False} and gc.isenabled()


@pytest.mark.parametrize("dtype, work", [(np.uint8, np.float32), (np.float32, np.float32), (np.uint8, np.float64)])
def test_halving_an_even_side_is_the_mean_of_each_pair_bit_for_bit(dtype, work):
    """The mip chains' box filter on an even side: the mean of each texel pair, as numpy's mean gives it."""
    from wit_plugin.texture.images import _halve

    rng = np.random.default_rng(3)
    image = (rng.random((64, 48, 3)) * 255).astype(dtype)
    for axis in (0, 1):
        pairs = image.reshape(image.shape[:axis] + (image.shape[axis] // 2, 2) + image.shape[axis + 1:])
        halved = _halve(image, axis, np.dtype(work))
        assert halved.dtype == np.dtype(work)
        np.testing.assert_array_equal(halved, pairs.mean(axis=axis + 1, dtype=work))
