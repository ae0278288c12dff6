"""Preview renderer: colours of textured roofs and ground, wall shading, z-buffer occlusion, holes, errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import gdal, ogr, osr

from wit_plugin import preview
from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback

X0, Y0 = 200000.0, 500000.0  # EPSG:5186 origin of the synthetic scenes
RED, BLUE, GREEN = (220, 30, 30), (30, 40, 220), (40, 170, 60)

Ring = list[tuple[float, float]]


def _srs() -> osr.SpatialReference:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    return srs


def _polygon(rings: list[list[tuple[float, float, float]]]) -> ogr.Geometry:
    poly = ogr.Geometry(ogr.wkbPolygon25D)
    for ring in rings:
        lr = ogr.Geometry(ogr.wkbLinearRing)
        for x, y, z in ring + ring[:1]:
            lr.AddPoint(X0 + x, Y0 + y, z)
        poly.AddGeometry(lr)
    return poly


def _layer(path: Path, name: str, fields: tuple[tuple[str, int], ...], geom_type: int = ogr.wkbPolygon25D):
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(name, _srs() if geom_type != ogr.wkbNone else None, geom_type)
    for field, kind in fields:
        layer.CreateField(ogr.FieldDefn(field, kind))
    return ds, layer


def _add(layer: ogr.Layer, values: dict, geometry: ogr.Geometry | None = None) -> None:
    feature = ogr.Feature(layer.GetLayerDefn())
    for key, value in values.items():
        feature.SetField(key, value)
    if geometry is not None:
        feature.SetGeometry(geometry)
    layer.CreateFeature(feature)


def _image(path: Path, rgb: tuple[int, int, int]) -> None:
    ds = gdal.GetDriverByName("MEM").Create("", 8, 8, 3, gdal.GDT_Byte)
    for b in range(3):
        ds.GetRasterBand(b + 1).Fill(rgb[b])
    gdal.GetDriverByName("PNG").CreateCopy(str(path), ds)


def _uv(ring: Ring) -> str:
    """Texture coordinates over the ring's bounding box, closing point included."""
    xy = np.array(ring + ring[:1], dtype=float)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    return " ".join(f"{v:.6f}" for v in ((xy - lo) / (hi - lo)).ravel())


def write_scene(folder: Path, buildings: list[tuple[str, Ring, list[Ring], float, tuple[int, int, int]]],
                ground: tuple[float, float, float, float] | None = None) -> tuple[str, str | None, str]:
    """LoD1 boxes (id, outer ring ccw, holes cw, height, roof colour), a flat TIN over ``ground``, textures."""
    tex = folder / "tex"
    tex.mkdir()
    tc_ds, tc = _layer(tex / step_layers.TEXCOORD_FILE, step_layers.TEXCOORD_TABLE,
                       ((step_layers.TEX_TARGET, ogr.OFTString), (step_layers.TEX_FEATURE, ogr.OFTString),
                        (step_layers.TEX_FACE, ogr.OFTInteger), (step_layers.TEX_IMAGE, ogr.OFTString),
                        (step_layers.TEX_COORDS, ogr.OFTString)), ogr.wkbNone)
    lod1_ds, lod1 = _layer(folder / "lod1.gpkg", step_layers.LOD1_LAYER,
                           ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                            (step_layers.FACE_NUMBER, ogr.OFTInteger)))
    for wit_id, outer, holes, height, colour in buildings:
        _image(tex / f"{wit_id}.png", colour)
        rings = [outer, *holes]
        faces = [("ground", [[(x, y, 0.0) for x, y in r[::-1]] for r in rings]),
                 ("roof", [[(x, y, height) for x, y in r] for r in rings])]
        for r in rings:
            for p, q in zip(r, r[1:] + r[:1]):
                faces.append(("wall", [[(*p, 0.0), (*q, 0.0), (*q, height), (*p, height)]]))
        for number, (kind, face) in enumerate(faces):
            _add(lod1, {step_layers.WIT_ID: wit_id, step_layers.FACE_TYPE: kind, step_layers.FACE_NUMBER: number},
                 _polygon(face))
        _add(tc, {step_layers.TEX_TARGET: "roof", step_layers.TEX_FEATURE: wit_id, step_layers.TEX_FACE: 1,
                  step_layers.TEX_IMAGE: f"{wit_id}.png", step_layers.TEX_COORDS: _uv(outer)})
    del lod1_ds
    tin_path = None
    if ground:
        _image(tex / "ground.png", GREEN)
        tin_path = str(folder / "tin.gpkg")
        tin_ds, tin = _layer(folder / "tin.gpkg", step_layers.TIN_LAYER,
                             ((step_layers.TIN_TRIANGLE_ID, ogr.OFTInteger), (step_layers.TIN_SURFACE, ogr.OFTString),
                              (step_layers.TIN_FEATURE_ID, ogr.OFTString)))
        xmin, ymin, xmax, ymax = ground
        xs, ys = np.linspace(xmin, xmax, 5), np.linspace(ymin, ymax, 5)
        tri_id = 0
        for i in range(4):
            for j in range(4):
                a, b, c, d = (xs[i], ys[j]), (xs[i + 1], ys[j]), (xs[i + 1], ys[j + 1]), (xs[i], ys[j + 1])
                for ring in ([a, b, c], [a, c, d]):
                    _add(tin, {step_layers.TIN_TRIANGLE_ID: tri_id, step_layers.TIN_SURFACE: "terrain"},
                         _polygon([[(x, y, 0.0) for x, y in ring]]))
                    uv = " ".join(f"{(x - xmin) / (xmax - xmin):.6f} {(y - ymin) / (ymax - ymin):.6f}"
                                  for x, y in ring + ring[:1])
                    _add(tc, {step_layers.TEX_TARGET: "tin", step_layers.TEX_FEATURE: str(tri_id),
                              step_layers.TEX_IMAGE: "ground.png", step_layers.TEX_COORDS: uv})
                    tri_id += 1
        del tin_ds
    del tc_ds
    return str(folder / "lod1.gpkg"), tin_path, str(tex)


def square(x0: float, y0: float, x1: float, y1: float) -> Ring:
    """Counter-clockwise ring of a rectangle."""
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def read_png(path: str) -> np.ndarray:
    ds = gdal.Open(path)
    return np.stack([ds.GetRasterBand(b + 1).ReadAsArray() for b in range(3)], axis=-1).astype(int)


def near(picture: np.ndarray, rgb: tuple[int, int, int], tolerance: int = 12) -> np.ndarray:
    return np.all(np.abs(picture - np.array(rgb)) <= tolerance, axis=-1)


@pytest.fixture
def no_haze(monkeypatch):
    """Exact surface colours: no distance haze."""
    monkeypatch.setattr(preview.shading, "HAZE_MAX", 0.0)


def test_textured_roofs_ground_and_shaded_walls(tmp_path, no_haze):
    lod1, tin, tex = write_scene(tmp_path, [("A", square(0, 0, 20, 20), [], 15.0, RED),
                                            ("B", square(40, 10, 60, 30), [], 25.0, BLUE)],
                                 ground=(-30, -30, 90, 70))
    out = str(tmp_path / "preview.png")
    report = preview.render_preview(lod1, tin, tex, out, width=400, height=250)
    picture = read_png(out)
    assert picture.shape == (250, 400, 3)
    assert report.triangles["roof"] == 4 and report.triangles["wall"] == 16 and report.triangles["terrain"] == 32
    assert report.textured_triangles == 36 and report.images == 3 and report.untextured_roofs == 0
    assert near(picture, RED).sum() > 300
    assert near(picture, BLUE).sum() > 300
    assert near(picture, GREEN).sum() > 5000
    # walls: the beige wall colour, visible in at least two clearly different brightnesses (lit / in shade)
    wall = np.array(preview.shading.WALL_RGB, float)
    factor = picture[..., 0] / wall[0]
    beige = np.all(np.abs(picture - factor[..., None] * wall) <= 4, axis=-1) & (factor > 0.3)
    levels = np.round(factor[beige], 2)
    values, counts = np.unique(levels, return_counts=True)
    common = values[counts > 100]
    assert len(common) >= 2 and common.max() - common.min() > 0.15


@pytest.mark.parametrize("blue_first", [True, False])
def test_front_building_hides_the_one_behind(tmp_path, blue_first):
    """Seen from the south, a red tower stands before a wide low blue block: the tower wins, in any file order.

    The block's triangles are larger on screen than the tower's, so the rasteriser draws them later:
    only the depth test keeps the tower's roof and front wall in front of the block's roof.
    """
    red = ("tower", square(-5, -5, 5, 5), [], 30.0, RED)
    blue = ("block", square(-40, 10, 40, 60), [], 8.0, BLUE)
    lod1, _, tex = write_scene(tmp_path, [blue, red] if blue_first else [red, blue])
    out = str(tmp_path / "preview.png")
    preview.render_preview(lod1, None, tex, out, width=300, height=300, azimuth_deg=180.0, elevation_deg=30.0)
    picture = read_png(out)
    red_mask, blue_mask = near(picture, RED, 40), near(picture, BLUE, 60)
    assert red_mask.sum() > 200 and blue_mask.sum() > 2000
    rows, cols = np.nonzero(red_mask)
    inner = slice(cols.min() + 3, cols.max() - 2)
    assert not blue_mask[rows.min():rows.max() + 1, inner].any()  # the roof and its edges
    assert not blue_mask[rows.max() + 1:rows.max() + 21, inner].any()  # the tower's front wall below it
    assert blue_mask[rows.min():rows.max() + 21, :cols.min() - 3].any()  # the block beside it


def test_roof_hole_shows_the_ground(tmp_path, no_haze):
    """From straight above, a courtyard building: red roof around, green ground in the courtyard."""
    hole = square(35, 35, 65, 65)[::-1]
    lod1, tin, tex = write_scene(tmp_path, [("court", square(0, 0, 100, 100), [hole], 5.0, RED)],
                                 ground=(-20, -20, 120, 120))
    out = str(tmp_path / "preview.png")
    preview.render_preview(lod1, tin, tex, out, width=200, height=200, elevation_deg=90.0)
    picture = read_png(out)
    assert near(picture[100, 100], GREEN).all()  # courtyard at the centre
    assert near(picture[100, 35], RED).all() and near(picture[35, 100], RED).all()  # roof west and north of it
    assert near(picture[100, 15], GREEN).all()  # ground outside


def test_without_tin_and_textures_flat_colours(tmp_path, no_haze):
    lod1, _, _ = write_scene(tmp_path, [("A", square(0, 0, 20, 20), [], 15.0, RED)])
    out = str(tmp_path / "preview.png")
    report = preview.render_preview(lod1, None, None, out, width=200, height=150)
    assert report.textured_triangles == 0 and report.triangles["terrain"] == 0
    assert near(read_png(out), preview.shading.ROOF_RGB, 3).sum() > 200


def test_self_intersecting_roof_is_still_drawn(tmp_path):
    bowtie = [(0.0, 0.0), (20.0, 20.0), (20.0, 0.0), (0.0, 20.0)]
    lod1, _, tex = write_scene(tmp_path, [("bow", bowtie, [], 10.0, RED)])
    out = str(tmp_path / "preview.png")
    report = preview.render_preview(lod1, None, tex, out, width=200, height=150)
    assert report.triangles["roof"] >= 2
    assert near(read_png(out), RED, 40).sum() > 200


def test_empty_or_wrong_inputs(tmp_path):
    ds, _ = _layer(tmp_path / "empty.gpkg", step_layers.LOD1_LAYER,
                   ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                    (step_layers.FACE_NUMBER, ogr.OFTInteger)))
    del ds
    out = tmp_path / "preview.png"
    with pytest.raises(InputError, match="Nothing to draw"):
        preview.render_preview(str(tmp_path / "empty.gpkg"), None, None, str(out))
    with pytest.raises(InputError, match="does not exist"):
        preview.render_preview(str(tmp_path / "missing.gpkg"), None, None, str(out))
    lod1, _, _ = write_scene(tmp_path, [("A", square(0, 0, 20, 20), [], 15.0, RED)])
    with pytest.raises(InputError, match="texture table"):
        preview.render_preview(lod1, None, str(tmp_path), str(out))
    with pytest.raises(InputError, match="elevation"):
        preview.render_preview(lod1, None, None, str(out), elevation_deg=0.0)
    assert not out.exists()


class _NoArrow:
    """An OGR layer as GDAL < 3.6 offers it: features one by one, no Arrow interface."""

    def __init__(self, layer: ogr.Layer):
        self._layer = layer

    def __iter__(self):
        return iter(self._layer)


def test_feature_loop_reads_like_arrow(tmp_path):
    lod1, tin, tex = write_scene(tmp_path, [("A", square(0, 0, 20, 20), [], 15.0, RED)], ground=(-30, -30, 50, 50))
    for path, name, fields in ((lod1, step_layers.LOD1_LAYER,
                                (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER)),
                               (tin, step_layers.TIN_LAYER, (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE)),
                               (str(Path(tex) / step_layers.TEXCOORD_FILE), step_layers.TEXCOORD_TABLE,
                                (step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_FACE,
                                 step_layers.TEX_COORDS))):
        with preview.scene._open_layer(path, name, "test", fields) as layer:
            arrow = preview.scene._read_columns(layer, fields, lambda g: shapely.get_coordinates(g, include_z=True))
            layer.ResetReading()
            loop = preview.scene._read_columns(_NoArrow(layer), fields,
                                               lambda g: shapely.get_coordinates(g, include_z=True))
        for key in (*fields, None):
            assert [v or 0 for v in loop[key].tolist()] == [v or 0 for v in arrow[key].tolist()], key


class _CancelAfter(Feedback):
    def __init__(self, percent: float):
        self.percent, self.reached = percent, 0.0

    def progress(self, percent: float) -> None:
        self.reached = max(self.reached, percent)

    def is_canceled(self) -> bool:
        return self.reached >= self.percent


@pytest.mark.parametrize("percent", [0.0, 20.0, 90.0])
def test_cancel_leaves_no_file(tmp_path, percent):
    lod1, tin, tex = write_scene(tmp_path, [("A", square(0, 0, 20, 20), [], 15.0, RED)], ground=(-30, -30, 50, 50))
    out = tmp_path / "preview.png"
    with pytest.raises(CanceledError):
        preview.render_preview(lod1, tin, tex, str(out), width=200, height=150, feedback=_CancelAfter(percent))
    assert not out.exists() and list(tmp_path.glob("*.png")) == []


def test_command_line(tmp_path):
    lod1, tin, tex = write_scene(tmp_path, [("A", square(0, 0, 20, 20), [], 15.0, RED)], ground=(-30, -30, 50, 50))
    out = tmp_path / "cli.png"
    assert preview.main([lod1, tin, tex, str(out), "--width", "120", "--height", "80"]) == 0
    assert read_png(str(out)).shape == (80, 120, 3)
    assert preview.main([lod1, "-", "-", str(out), "--elevation", "0"]) == 1
