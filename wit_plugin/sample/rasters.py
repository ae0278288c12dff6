"""Synthetic rasters for the sample data: an NGII-like DEM and unreferenced NGII orthoimage tiles.

The terrain is defined in EPSG:5186 metres: the real hills south-west of Suseo station (대모산,
구룡산, 인릉산) as Gaussian bumps, seeded low hills elsewhere, and multi-octave value noise (smooth,
C² fade) that is rougher on the hills. The DEM keeps a few cells at -9999 without declaring
NoData, exactly like the real Seoul DEM.

Orthoimage tiles are rendered where the vectors are: geometries are rasterised per horizontal
strip with ``gdal.RasterizeLayer`` into class and building-id bands, then coloured with numpy
(per-class palette, multi-octave texture, per-building roof colour, ridge shading on pitched
roofs, parapets, cast shadows) so that memory stays bounded whatever the tile size.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
from osgeo import gdal, ogr, osr
from pyproj import Transformer

from ..infra.feedback import SILENT, Feedback
from ..infra.io.raster_io import read_window
from .blocks import footprints
from .gangnam import GROUND_BARE, GROUND_FOREST, GROUND_LANE, GROUND_LAWN, GROUND_PARKING, PITCHED_ROOFS
from .layout import CityLayout

NO_DATA_HOLE = -9999.0
SUSEO_STATION_5186 = (209020.888, 543132.772)
# (dx, dy) from Suseo station in EPSG:5186 m, height above the valley floor, sigma x, sigma y
_NAMED_HILLS = (
    (-1794.0, -1378.0, 225.0, 520.0, 420.0),  # 대모산 293 m
    (-3873.0, -1701.0, 225.0, 560.0, 460.0),  # 구룡산 306 m
    (-2830.0, -1560.0, 110.0, 900.0, 330.0),  # the ridge between them
    (-614.0, -4562.0, 295.0, 700.0, 600.0),  # 인릉산 327 m
)
_VALLEY_FLOOR = 15.0
_NOISE_OCTAVES = ((600.0, 7.0), (190.0, 3.0), (55.0, 1.0))
_HILL_CELL = 2500.0


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def value_noise(x: np.ndarray, y: np.ndarray, cell: float, table: np.ndarray) -> np.ndarray:
    """Smooth lattice noise in [-1, 1] at broadcastable coordinate arrays (periodic table)."""
    gx, gy = x / cell, y / cell
    fx, fy = np.floor(gx), np.floor(gy)
    tx, ty = _fade(gx - fx).astype(np.float32), _fade(gy - fy).astype(np.float32)
    size = table.shape[0]
    ix, iy = fx.astype(np.int64) % size, fy.astype(np.int64) % size
    ix1, iy1 = (ix + 1) % size, (iy + 1) % size
    low = table[iy, ix] + (table[iy, ix1] - table[iy, ix]) * tx
    high = table[iy1, ix] + (table[iy1, ix1] - table[iy1, ix]) * tx
    return low + (high - low) * ty


def noise_tables(seed: int, stream: int, count: int) -> np.ndarray:
    return np.random.default_rng([seed, stream]).uniform(-1.0, 1.0, (count, 256, 256)).astype(np.float32)


class Terrain:
    """Ground height in metres at EPSG:5186 points; ``x`` and ``y`` broadcast (grids: (1, nx), (ny, 1))."""

    def __init__(self, seed: int):
        self.seed = seed
        self._tables = noise_tables(seed, 20, len(_NOISE_OCTAVES))

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        hills = np.zeros(np.broadcast_shapes(x.shape, y.shape))
        for cx, cy, height, sx, sy in self._hills(x, y):
            hills += height * np.exp(-0.5 * ((x - cx) / sx) ** 2) * np.exp(-0.5 * ((y - cy) / sy) ** 2)
        rough = 1.0 + hills / 150.0
        h = _VALLEY_FLOOR + hills
        for (cell, amp), table in zip(_NOISE_OCTAVES, self._tables):
            h += amp * rough * value_noise(x, y, cell, table)
        return np.maximum(h, 2.0)

    def _hills(self, x: np.ndarray, y: np.ndarray):
        """Named hills plus one seeded low hill per 2.5 km cell (keyed by the cell, not the request)."""
        x0, y0 = SUSEO_STATION_5186
        hills = [(x0 + dx, y0 + dy, h, sx, sy) for dx, dy, h, sx, sy in _NAMED_HILLS]
        c0, c1 = int((x.min() - 3000) // _HILL_CELL), int((x.max() + 3000) // _HILL_CELL)
        r0, r1 = int((y.min() - 3000) // _HILL_CELL), int((y.max() + 3000) // _HILL_CELL)
        for c in range(c0, c1 + 1):
            for r in range(r0, r1 + 1):
                rng = np.random.default_rng([self.seed, 21, c, r])
                if rng.random() < 0.55:
                    px, py = (c + rng.random()) * _HILL_CELL, (r + rng.random()) * _HILL_CELL
                    hills.append((px, py, rng.uniform(10.0, 45.0), rng.uniform(200.0, 450.0),
                                  rng.uniform(200.0, 450.0)))
        return hills


def _srs_wkt(epsg: int) -> str:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    return srs.ExportToWkt()


def write_dem(path: Path, bounds: tuple[float, float, float, float], cell: float, terrain: Terrain,
              rng: np.random.Generator, feedback: Feedback = SILENT) -> int:
    """Write a Float32 GeoTIFF (EPSG:5186) over ``bounds``; returns the number of -9999 cells.

    About 0.05 % of the cells (at least 3) hold -9999 and no NoData value is declared, like the
    real Seoul DEM, so that readers must cope with undeclared holes.
    """
    x0, y0 = np.floor(bounds[0] / cell) * cell, np.floor(bounds[1] / cell) * cell
    x1, y1 = np.ceil(bounds[2] / cell) * cell, np.ceil(bounds[3] / cell) * cell
    nx, ny = int(round((x1 - x0) / cell)), int(round((y1 - y0) / cell))
    holes = rng.choice(nx * ny, size=max(3, round(nx * ny * 0.0005)), replace=False)
    ds = gdal.GetDriverByName("GTiff").Create(str(path), nx, ny, 1, gdal.GDT_Float32, ["TILED=YES"])
    ds.SetGeoTransform((x0, cell, 0.0, y1, 0.0, -cell))
    ds.SetProjection(_srs_wkt(5186))
    band = ds.GetRasterBand(1)
    xs = (x0 + (np.arange(nx) + 0.5) * cell)[None, :]
    step = 256
    for r in range(0, ny, step):
        feedback.check_canceled()
        rows = np.arange(r, min(r + step, ny))
        block = terrain(xs, (y1 - (rows + 0.5) * cell)[:, None]).astype(np.float32)
        inside = holes[(holes >= r * nx) & (holes < (rows[-1] + 1) * nx)] - r * nx
        block.reshape(-1)[inside] = NO_DATA_HOLE
        band.WriteArray(block, 0, int(r))
        feedback.progress(100.0 * (rows[-1] + 1) / ny)
    ds = None
    return len(holes)


# --- orthoimages --------------------------------------------------------------------------------

SIDEWALK, ASPHALT, WHITE_LINE, YELLOW_LINE, TREE = 0, 6, 7, 8, 9
NATURAL = 10  # open ground whose cover (lawn, forest, bare soil) is chosen per pixel from smooth noise
# class → RGB, and texture amplitudes (coarse 24 m, medium 5 m, fine 1.2 m, per pixel)
_PALETTE = np.zeros((11, 3), np.float32)
_TEXTURE = np.zeros((11, 4), np.float32)
for _cls, _rgb, _tex in (
        (SIDEWALK, (170, 163, 154), (0.05, 0.05, 0.04, 0.05)),
        (GROUND_LAWN, (98, 128, 72), (0.12, 0.14, 0.10, 0.08)),
        (GROUND_FOREST, (54, 80, 44), (0.15, 0.22, 0.25, 0.12)),
        (GROUND_BARE, (182, 152, 114), (0.06, 0.06, 0.04, 0.05)),
        (GROUND_PARKING, (112, 112, 110), (0.04, 0.05, 0.03, 0.05)),
        (GROUND_LANE, (146, 141, 134), (0.06, 0.06, 0.05, 0.06)),
        (ASPHALT, (80, 82, 85), (0.05, 0.05, 0.03, 0.05)),
        (WHITE_LINE, (226, 226, 218), (0.02, 0.02, 0.02, 0.03)),
        (YELLOW_LINE, (218, 178, 62), (0.02, 0.02, 0.02, 0.03)),
        (TREE, (62, 96, 50), (0.10, 0.20, 0.28, 0.10))):
    _PALETTE[_cls], _TEXTURE[_cls] = _rgb, _tex
_TEXTURE_CELLS = (24.0, 5.0, 1.2)
ROOF_COLOURS = np.array([(178, 176, 171), (92, 156, 116), (164, 74, 58), (124, 86, 62), (72, 112, 162),
                         (212, 210, 204), (98, 104, 112)], np.float32)
SHADOW_TINT = np.array([0.56, 0.59, 0.70], np.float32)


@dataclass
class OrthoScene:
    """What the orthoimage shows, in EPSG:5186: layers to rasterise plus per-building roof data."""

    ground: tuple[np.ndarray, np.ndarray]  # polygons, class
    roads: tuple[np.ndarray, np.ndarray]  # polygons (road surfaces) and lines (markings), class
    trees: np.ndarray  # crown polygons
    shadows: np.ndarray  # shadow polygons
    roofs: np.ndarray  # building polygons (id = index + 1)
    roof_rgb: np.ndarray  # (n, 3)
    ridge: np.ndarray  # (n, 4): centre x, y and unit normal of the ridge; normal 0 for flat roofs


class Rasteriser:
    """In-memory OGR layers of the scene, burnt strip by strip into a 3-band Int32 MEM raster."""

    def __init__(self, scene: OrthoScene):
        self._ds = ogr.GetDriverByName("Memory").CreateDataSource("scene")
        self._srs = osr.SpatialReference()
        self._srs.ImportFromEPSG(5186)
        self._srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)  # x = easting, as the geometries
        ground_geoms, ground_cls = scene.ground
        road_geoms, road_cls = scene.roads
        edges = grouped(shapely.boundary(scene.roofs))
        self.passes = [  # (layer, band, use the attribute or burn value)
            (self._layer("ground", ground_geoms, ground_cls), 1),
            (self._layer("roads", road_geoms, road_cls), 1),
            (self._layer("trees", scene.trees, np.full(len(scene.trees), TREE)), 1),
            (self._layer("shadows", scene.shadows, np.ones(len(scene.shadows))), 2),
            (self._layer("roofs", scene.roofs, np.arange(1, len(scene.roofs) + 1)), 3),
            (self._layer("parapets", edges, np.full(len(edges), 2)), 2),
        ]

    def _layer(self, name: str, geoms: np.ndarray, values: np.ndarray) -> ogr.Layer:
        layer = self._ds.CreateLayer(name, srs=self._srs, geom_type=ogr.wkbUnknown)
        layer.CreateField(ogr.FieldDefn("v", ogr.OFTInteger))
        defn = layer.GetLayerDefn()
        layer.StartTransaction()
        for wkb, value in zip(shapely.to_wkb(geoms), values):
            feature = ogr.Feature(defn)
            feature.SetGeometryDirectly(ogr.CreateGeometryFromWkb(wkb))
            feature.SetField(0, int(value))
            layer.CreateFeature(feature)
        layer.CommitTransaction()
        return layer

    def burn(self, x0: float, y_top: float, pixel: tuple[float, float], width: int, height: int) -> np.ndarray:
        """Class, mark and building-id bands of the strip; ``pixel`` = (width, height) of a pixel in metres."""
        mem = gdal.GetDriverByName("MEM").Create("", width, height, 3, gdal.GDT_Int32)
        mem.SetGeoTransform((x0, pixel[0], 0.0, y_top, 0.0, -pixel[1]))
        mem.SetSpatialRef(self._srs)
        for layer, band in self.passes:
            layer.SetSpatialFilterRect(x0, y_top - height * pixel[1], x0 + width * pixel[0], y_top)
            gdal.RasterizeLayer(mem, [band], layer, options=["ATTRIBUTE=v"])
            layer.SetSpatialFilter(None)
        return read_window(mem, 0, 0, width, height, "the rasterised sample scene (in memory)")


def render_tile(path: Path, envelope: tuple[float, float, float, float], pixel: float, scene: OrthoScene,
                rasteriser: Rasteriser, gain: np.ndarray, seed: int, tables: np.ndarray,
                feedback: Feedback = SILENT) -> tuple[int, int]:
    """Render one plain RGB TIFF (no georeferencing) over ``envelope``; returns (width, height).

    The pixels fill the envelope exactly (their size is the envelope's extent over their number, a
    hair off ``pixel``), as wit:georeferencemapsheets places them. ``gain`` (3 values) is the tile's
    own exposure and white balance, so that neighbouring tiles differ in their overlap as real
    flight strips do.
    """
    xmin, ymin, xmax, ymax = envelope
    width, height = int(round((xmax - xmin) / pixel)), int(round((ymax - ymin) / pixel))
    size = ((xmax - xmin) / width, (ymax - ymin) / height)
    ds = gdal.GetDriverByName("GTiff").Create(
        str(path), width, height, 3, gdal.GDT_Byte,
        ["PHOTOMETRIC=RGB", "INTERLEAVE=PIXEL", "PROFILE=BASELINE", "TFW=NO", "COMPRESS=NONE"])
    xs = (xmin + (np.arange(width) + 0.5) * size[0])[None, :]
    strip = max(16, int(2_000_000 // width))
    rng = np.random.default_rng([seed, 30, int(xmin), int(ymax)])
    for row in range(0, height, strip):
        feedback.check_canceled()
        h = min(strip, height - row)
        y_top = ymax - row * size[1]
        bands = rasteriser.burn(xmin, y_top, size, width, h)
        ys = (y_top - (np.arange(h) + 0.5) * size[1])[:, None]
        rgb = _colour(bands, xs, ys, scene, tables, rng) * gain
        ds.WriteRaster(0, row, width, h, np.clip(rgb, 0, 255).astype(np.uint8).tobytes(), band_list=[1, 2, 3],
                       buf_pixel_space=3, buf_line_space=3 * width, buf_band_space=1)
        feedback.progress(100.0 * (row + h) / height)
    ds = None
    return width, height


def _natural_cover(cls: np.ndarray, xs: np.ndarray, ys: np.ndarray, tables: np.ndarray) -> np.ndarray:
    """``cls`` with NATURAL pixels turned into patches of lawn, forest and bare soil (~150 m noise)."""
    rows, cols = np.nonzero(cls == NATURAL)
    if len(rows) == 0:
        return cls
    x, y = xs[0, cols], ys[rows, 0]
    noise = value_noise(x, y, 150.0, tables[0]) + 0.5 * value_noise(x, y, 40.0, tables[1])
    cls = cls.copy()
    cls[rows, cols] = np.where(noise > 0.3, GROUND_FOREST, np.where(noise < -0.75, GROUND_BARE, GROUND_LAWN))
    return cls


def _colour(bands: np.ndarray, xs: np.ndarray, ys: np.ndarray, scene: OrthoScene, tables: np.ndarray,
            rng: np.random.Generator) -> np.ndarray:
    cls, marks, bid = _natural_cover(bands[0], xs, ys, tables), bands[1], bands[2]
    coarse, medium, fine = (value_noise(xs, ys, cell, table) for cell, table in zip(_TEXTURE_CELLS, tables))
    grain = rng.standard_normal(cls.shape, dtype=np.float32)
    amp = _TEXTURE[cls]
    texture = 1.0 + amp[..., 0] * coarse + amp[..., 1] * medium + amp[..., 2] * fine + amp[..., 3] * grain
    rgb = _PALETTE[cls] * texture[..., None]
    shadow = (marks == 1) & (bid == 0)
    rgb[shadow] *= SHADOW_TINT
    roof = bid > 0
    if roof.any():
        rows, cols = np.nonzero(roof)
        k = bid[rows, cols] - 1
        shade = 1.0 + 0.05 * medium[rows, cols] + 0.04 * fine[rows, cols] + 0.03 * grain[rows, cols]
        cx, cy, nx, ny = scene.ridge[k].T
        side = (xs[0, cols] - cx) * nx + (ys[rows, 0] - cy) * ny
        pitched = (nx != 0) | (ny != 0)
        shade = np.where(pitched, shade * np.where(side > 0, 1.1, 0.82), shade)
        shade = np.where(pitched & (np.abs(side) < 0.35), shade * 1.25, shade)
        edge = marks[rows, cols] == 2
        shade = np.where(edge, np.where(pitched, shade * 0.8, shade * 1.14), shade)
        rgb[rows, cols] = scene.roof_rgb[k] * shade[:, None].astype(np.float32)
    return rgb


def build_scene(layout: CityLayout, bbox: tuple[float, float, float, float], seed: int) -> OrthoScene:
    """Everything visible in ``bbox`` (EPSG:5179), transformed to EPSG:5186 for rendering."""
    superblocks = layout.superblocks(bbox)
    rng = np.random.default_rng([seed, 50])
    ground = [(shapely.Polygon(ring), cls) for sb in superblocks for ring, cls in sb.ground]
    lines, widths = _road_lines(layout, superblocks)
    surfaces = shapely.buffer(lines, widths / 2, cap_style="flat", join_style="round")
    trees = np.array([t for sb in superblocks for t in sb.trees] or np.zeros((0, 3))).reshape(-1, 3)
    along_streets = street_trees(lines, widths, rng)
    buildings = [b for sb in superblocks for b in sb.buildings]
    heights = np.array([3.0 * max(b.floors, 1) for b in buildings])
    roof_style = np.array([b.roof for b in buildings], dtype=int)
    roof_rgb = ROOF_COLOURS[roof_style] * rng.uniform(0.88, 1.12, (len(buildings), 1)) \
        * rng.uniform(0.96, 1.04, (len(buildings), 3))
    to_5186 = Transformer.from_crs("EPSG:5179", "EPSG:5186", always_xy=True)

    def project(geoms):
        return shapely.transform(np.asarray(geoms, dtype=object),
                                 lambda c: np.column_stack(to_5186.transform(c[:, 0], c[:, 1])))

    return assemble_scene((project([g for g, _ in ground]), np.array([c for _, c in ground], dtype=int)),
                          surfaces, lines, widths, np.vstack([along_streets, trees]), project(footprints(buildings)),
                          heights, roof_rgb, np.isin(roof_style, PITCHED_ROOFS), project)


def assemble_scene(ground: tuple[np.ndarray, np.ndarray], surfaces: np.ndarray, lines: np.ndarray,
                   widths: np.ndarray, trees: np.ndarray, roofs: np.ndarray, heights: np.ndarray,
                   roof_rgb: np.ndarray, pitched: np.ndarray, project=lambda geoms: geoms) -> OrthoScene:
    """The scene from its parts: road ``surfaces`` and centre ``lines`` (for the markings), tree
    (x, y, crown radius) rows, and for every roof its height (shadow), colour and whether it is pitched.

    ``project`` takes the road and tree geometries into EPSG:5186; ``ground`` and ``roofs`` are in it.
    """
    markings, marking_cls = _markings(lines, widths)
    return OrthoScene(
        ground=ground,
        roads=(project(np.concatenate([surfaces, markings])),
               np.concatenate([np.full(len(surfaces), ASPHALT), marking_cls]).astype(int)),
        trees=_crowns(trees, project), shadows=grouped(_shadows(roofs, heights)), roofs=roofs,
        roof_rgb=np.asarray(roof_rgb, np.float32), ridge=_ridges(roofs, pitched))


def _road_lines(layout: CityLayout, superblocks: list) -> tuple[np.ndarray, np.ndarray]:
    ii = [sb.index[0] for sb in superblocks]
    jj = [sb.index[1] for sb in superblocks]
    lines, widths = [], []
    for family, indices, span in (("u", range(min(ii), max(ii) + 2), (min(jj), max(jj) + 1)),
                                  ("v", range(min(jj), max(jj) + 2), (min(ii), max(ii) + 1))):
        for index in indices:
            for run in layout.arterial_runs(family, index, *span):
                lines.append(shapely.LineString(run))
                widths.append(layout.arterial(family, index)[3])
    for sb in superblocks:
        for road in sb.roads:
            lines.append(shapely.LineString(road.coords))
            widths.append(road.width)
    return np.array(lines, dtype=object), np.array(widths)


def _dashes(line, on: float, off: float) -> list:
    stops = np.arange(0.0, line.length - on, on + off)
    if len(stops) == 0:
        return []
    starts = shapely.line_interpolate_point(line, stops)
    ends = shapely.line_interpolate_point(line, stops + on)
    return list(shapely.linestrings(np.stack([shapely.get_coordinates(starts), shapely.get_coordinates(ends)], 1)))


def _markings(lines: np.ndarray, widths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Yellow double centre lines on roads of 15 m and more, dashed white lane lines every 3.4 m."""
    yellow, white = [], []
    for line, width in zip(lines, widths):
        if width < 15.0:
            continue
        yellow += [shapely.offset_curve(line, side) for side in (-0.25, 0.25)]
        for k in range(1, int((width / 2 - 1.5) // 3.4)):
            for sign in (-1, 1):
                white += _dashes(shapely.offset_curve(line, sign * 3.4 * k), 3.0, 5.0)
    yellow_lines, white_lines = grouped(np.array(yellow, dtype=object)), grouped(np.array(white, dtype=object))
    return (np.concatenate([yellow_lines, white_lines]),
            np.array([YELLOW_LINE] * len(yellow_lines) + [WHITE_LINE] * len(white_lines)))


def street_trees(lines: np.ndarray, widths: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(x, y, crown radius) on both sidewalks of every road of 15 m and more, every ~9 m."""
    trees = [np.zeros((0, 3))]
    for line, width in zip(lines, widths):
        if width < 15.0:
            continue
        for sign in (-1, 1):
            edge = shapely.offset_curve(line, sign * (width / 2 + 1.6))
            xy = shapely.get_coordinates(shapely.line_interpolate_point(edge, np.arange(4.0, edge.length, 9.0)))
            trees.append(np.column_stack([xy, rng.uniform(1.8, 2.8, len(xy))]))
    return np.vstack(trees)


def _crowns(trees: np.ndarray, project) -> np.ndarray:
    """Tree crowns as polygons in EPSG:5186, grouped in multipolygons (fewer features to burn)."""
    crowns = shapely.buffer(project(shapely.points(trees[:, :2])), trees[:, 2], quad_segs=3)
    return grouped(crowns)


def grouped(geoms: np.ndarray, size: int = 256) -> np.ndarray:
    """Consecutive (hence nearby) geometries merged into collections of ``size``, to burn one value."""
    return np.array([shapely.geometrycollections(geoms[k:k + size]) for k in range(0, len(geoms), size)],
                    dtype=object)


def _shadows(roofs: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """Cast shadows toward north-north-west (late-morning sun, 58° high): hull of footprint + offset."""
    if len(roofs) == 0:
        return roofs
    index = shapely.get_coordinates(roofs, return_index=True)[1]
    length = heights[index] / np.tan(np.radians(58.0))
    offsets = length[:, None] * np.array([np.sin(np.radians(335.0)), np.cos(np.radians(335.0))])
    shifted = shapely.transform(roofs, lambda c: c + offsets)
    return shapely.convex_hull(shapely.geometrycollections(np.column_stack([roofs, shifted])))


def _ridges(roofs: np.ndarray, pitched: np.ndarray) -> np.ndarray:
    """Ridge line (centre, unit normal) along the long axis of each pitched roof; zeros when flat."""
    ridge = np.zeros((len(roofs), 4))
    if not pitched.any():
        return ridge
    boxes = shapely.oriented_envelope(roofs[pitched])
    corners = shapely.get_coordinates(shapely.get_exterior_ring(boxes)).reshape(-1, 5, 2)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 1]
    long_axis = np.where((np.hypot(*e1.T) >= np.hypot(*e2.T))[:, None], e1, e2)
    long_axis /= np.hypot(*long_axis.T)[:, None]
    ridge[pitched, :2] = corners[:, :4].mean(axis=1)
    ridge[pitched, 2:] = np.column_stack([-long_axis[:, 1], long_axis[:, 0]])
    return ridge


# Roof styles of buildings whose roof is unknown (given layers), by footprint area: (upper bound m², weights
# of ROOF_COLOURS); small buildings are often houses with tiled, pitched roofs, large ones flat and pale.
_ROOFS_BY_SIZE = ((200.0, (0.25, 0.22, 0.2, 0.15, 0.12, 0.06, 0.0)),
                  (1500.0, (0.4, 0.15, 0.0, 0.0, 0.1, 0.2, 0.15)),
                  (np.inf, (0.45, 0.0, 0.0, 0.0, 0.1, 0.25, 0.2)))


def roof_styles(roofs: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(RGB, pitched) per footprint, drawn from its area and a random stream keyed by its centroid.

    Keyed by position (to 0.1 m), not by feature order: a building keeps its roof whatever area or
    layer it is drawn in.
    """
    centres = np.round(shapely.get_coordinates(shapely.centroid(roofs)) * 10).astype(np.int64)
    draws = np.array([np.random.default_rng([seed, 52, int(x) & 0xFFFFFFFF, int(y) & 0xFFFFFFFF]).random(5)
                      for x, y in centres]).reshape(-1, 5)
    size_class = np.searchsorted([bound for bound, _ in _ROOFS_BY_SIZE], shapely.area(roofs))
    cumulative = np.cumsum([weights for _, weights in _ROOFS_BY_SIZE], axis=1)
    cumulative /= cumulative[:, -1:]
    style = (draws[:, :1] >= cumulative[size_class]).sum(axis=1)
    rgb = ROOF_COLOURS[style] * (0.88 + 0.24 * draws[:, 1:2]) * (0.96 + 0.08 * draws[:, 2:5])
    return rgb.astype(np.float32), np.isin(style, PITCHED_ROOFS)
