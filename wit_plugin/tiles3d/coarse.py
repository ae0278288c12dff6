"""Coarse terrain for the upper tiles: a height grid and an image per tile, built bottom-up.

Each tile of the quadtree gets a *patch*: heights at the (n + 1)² vertices of a regular grid over its
square (row 0 on the north edge, NaN where nothing is known), an r × r RGB image of the same square and
which of its n² cells hold anything of the leaves below (``covered``). A leaf samples its patch from the
TIN triangles meeting it and from the roofs over it: heights by barycentric interpolation (the ground
height under a roof: a TIN leaves a building's footprint out when the building stands on it), colours
from the ground images and roof atlases at the mip level nearest the patch's texel size. Every cell
holding a piece of ground or roof is drawn, its unknown corners filled from their neighbours and its
texels without a surface given their neighbours' colours: the coarse terrain covers the ground wherever
the leaves do, under the buildings too (which a coarse level may leave out), and never shows a hole
from afar. A parent takes every other height of its four children, their images halved (2 × 2 averages)
and their cells (a parent cell holds content when one of its four does), so the whole model is never
read at once and no ground image is read more than once per leaf.

The parent's vertical error is measured: the largest difference between its grid (bilinear between
its vertices) and its children's grids at their vertices, plus the children's own error.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from osgeo import gdal

from ..infra.io.raster_io import fill_nodata
from .store import TriangleRows
from .textures import TextureSet

NO_COLOUR = 128
FILL_TEXELS = 16  # texels a colour spreads into the texels of a drawn cell that no surface covers
_CANDIDATES = 1 << 13
"""Grid points tested per chunk of triangles: bounds memory, and keeps the chunk's twenty-odd temporaries small enough
for the CPU's caches (the 1 km sample's leaves located alone: 2^18 took twice the time of 2^13)."""


@dataclass
class Patch:
    heights: np.ndarray  # (n + 1, n + 1) float64, NaN = no terrain
    image: np.ndarray  # (r, r, 3) uint8
    error: float  # vertical error of the heights against the TIN (m)
    covered: np.ndarray | None = None  # (n, n) cells holding ground or roofs below; None: where 4 heights are


def locate(xy: np.ndarray, x0: float, y_top: float, step: float, rows: int, cols: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """The triangle (index into ``xy`` (t, 3, 2), -1 if none) and barycentric weights at each point of
    the grid x = x0 + j·step, y = y_top − i·step; flat arrays of rows × cols."""
    found = np.full(rows * cols, -1, dtype=np.int64)
    weights = np.zeros((rows * cols, 3))
    if len(xy) == 0:
        return found, weights
    lo = np.minimum(np.minimum(xy[:, 0], xy[:, 1]), xy[:, 2])  # (elementwise: faster than min over an axis of 3)
    hi = np.maximum(np.maximum(xy[:, 0], xy[:, 1]), xy[:, 2])
    c0 = np.clip(np.ceil((lo[:, 0] - x0) / step - 1e-9), 0, cols).astype(np.int64)
    c1 = np.clip(np.floor((hi[:, 0] - x0) / step + 1e-9), -1, cols - 1).astype(np.int64)
    r0 = np.clip(np.ceil((y_top - hi[:, 1]) / step - 1e-9), 0, rows).astype(np.int64)
    r1 = np.clip(np.floor((y_top - lo[:, 1]) / step + 1e-9), -1, rows - 1).astype(np.int64)
    # per triangle once, gathered per candidate point: its first corner, edges from it and determinant
    ax, ay = xy[:, 0, 0].copy(), xy[:, 0, 1].copy()
    bax, bay, cax, cay = xy[:, 1, 0] - ax, xy[:, 1, 1] - ay, xy[:, 2, 0] - ax, xy[:, 2, 1] - ay
    det = bax * cay - cax * bay
    ncol, nrow = np.maximum(c1 - c0 + 1, 0), np.maximum(r1 - r0 + 1, 0)
    count = np.where(det != 0, ncol * nrow, 0)  # a degenerate triangle holds no point
    width = np.maximum(ncol, 1)
    ends = np.cumsum(count)
    start = 0
    while start < len(xy):
        stop = int(np.searchsorted(ends, (ends[start - 1] if start else 0) + _CANDIDATES, side="right"))
        stop = max(stop, start + 1)
        chunk = np.arange(start, stop)
        tri = np.repeat(chunk, count[chunk])
        k = np.arange(len(tri)) - np.repeat(np.cumsum(count[chunk]) - count[chunk], count[chunk])
        row_in, col_in = np.divmod(k, width[tri])
        col, row = c0[tri] + col_in, r0[tri] + row_in
        dx, dy = x0 + col * step - ax[tri], y_top - row * step - ay[tri]
        d = det[tri]
        w1 = (dx * cay[tri] - cax[tri] * dy) / d
        w2 = (bax[tri] * dy - dx * bay[tri]) / d
        w0 = 1.0 - w1 - w2
        inside = np.flatnonzero((w0 >= -1e-9) & (w1 >= -1e-9) & (w2 >= -1e-9))
        cell = row[inside] * cols + col[inside]
        found[cell] = tri[inside]
        weights[cell, 0], weights[cell, 1], weights[cell, 2] = w0[inside], w1[inside], w2[inside]
        start = stop
    return found, weights


def leaf_patch(triangles: TriangleRows, roofs: TriangleRows, rect: tuple[float, float, float, float], cells: int,
               size: int, textures: TextureSet | None) -> Patch:
    """Sample a leaf's patch from the TIN triangles meeting its square ``rect`` and the ``roofs`` over it
    (triangles at their building's ground height, with their roof atlas's texture rows)."""
    xmin, _, xmax, ymax = rect
    side = xmax - xmin
    heights = np.full((cells + 1) ** 2, np.nan)
    for surfaces in (roofs, triangles):  # the TIN's own height where it has one
        tri, w = locate(surfaces.xyz[:, :, :2], xmin, ymax, side / cells, cells + 1, cells + 1)
        hit = tri >= 0
        heights[hit] = (surfaces.xyz[tri[hit], :, 2] * w[hit]).sum(axis=1)
    step = side / size
    rgb = np.full((size * size, 3), NO_COLOUR, dtype=np.uint8)
    hit = np.zeros(size * size, dtype=bool)
    for surfaces in (roofs, triangles):  # a roof seen from above where a TIN also has a (footprint) triangle
        tri, w = locate(surfaces.xyz[:, :, :2], xmin + step / 2, ymax - step / 2, step, size, size)
        colours, found = _colours(surfaces, tri, w, step, textures)
        np.copyto(rgb, colours, where=found[:, None])  # (a masked copy: masking rows of 3 bytes is slower)
        hit |= found
    texel_cell = np.arange(size) * cells // size
    covered = np.zeros((cells, cells), dtype=bool)
    rows, cols = np.divmod(np.flatnonzero(hit), size)
    covered[texel_cell[rows], texel_cell[cols]] = True
    corners = np.concatenate([roofs.xyz[:, :, :2].reshape(-1, 2), triangles.xyz[:, :, :2].reshape(-1, 2)])
    cell = np.floor(np.column_stack([ymax - corners[:, 1], corners[:, 0] - xmin]) / (side / cells)).astype(np.int64)
    inside = ((cell >= 0) & (cell < cells)).all(axis=1)  # a sliver between texel centres still has its corners
    covered[cell[inside, 0], cell[inside, 1]] = True
    return Patch(fill_heights(heights.reshape(cells + 1, cells + 1), covered),
                 fill_colours(rgb.reshape(size, size, 3), hit.reshape(size, size)), 0.0, covered)


def _colours(triangles: TriangleRows, tri: np.ndarray, w: np.ndarray, step: float,
             textures: TextureSet | None) -> tuple[np.ndarray, np.ndarray]:
    """Texel colours from the triangles' images at the mip level nearest ``step`` (the neutral colour for an
    untextured one), and which texels lie on a triangle."""
    rgb = np.full((len(tri), 3), NO_COLOUR, dtype=np.uint8)
    image = np.full(len(tri), -1, dtype=np.int64)
    hit = tri >= 0
    image[hit] = triangles.image[tri[hit]]  # (a leaf may meet no triangle at all: only its buildings)
    if textures is None:
        return rgb, hit
    numbers = np.unique(image[image >= 0]).tolist()
    levels = _mip_levels(triangles, {number: textures.shape(number) for number in numbers}, step)
    corner_uvs = triangles.uv.reshape(-1, 6)  # (rows gathered with take: faster than fancy indexing)
    for number in numbers:
        texels = np.flatnonzero(image == number)
        corner_uv = np.take(corner_uvs, tri[texels], axis=0).reshape(-1, 3, 2)
        weight = np.take(w, texels, axis=0)
        u, v = ((corner_uv[:, 0, k] * weight[:, 0] + corner_uv[:, 1, k] * weight[:, 1]
                 + corner_uv[:, 2, k] * weight[:, 2]) for k in (0, 1))  # (a sum over the axis of 3, unrolled)
        pixels = textures.level(number, levels[number])
        h, wd = pixels.shape[:2]
        col = np.clip((u * wd).astype(np.int64), 0, wd - 1)
        row = np.clip(((1.0 - v) * h).astype(np.int64), 0, h - 1)  # texture-table v grows upwards
        rgb[texels] = np.take(pixels.reshape(-1, pixels.shape[2]), row * wd + col, axis=0)
    return rgb, hit


def fill_heights(heights: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """``heights`` with the unknown corners of the ``covered`` cells taken from their known neighbours (a
    roof's edge off the TIN, a cell reaching beyond the area), in place; corners still unknown then (a cell
    with no known height around it) leave their cell undrawn."""
    needed = np.zeros(heights.shape, dtype=bool)
    for dy in (0, 1):
        for dx in (0, 1):
            needed[dy:dy + covered.shape[0], dx:dx + covered.shape[1]] |= covered
    for _ in range(max(heights.shape)):
        missing = needed & np.isnan(heights)
        if not missing.any():
            break
        heights[missing] = neighbour_mean(heights)[missing]
    return heights


def fill_colours(rgb: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """The texels no surface covers take their neighbours' colours (GDAL's inverse-distance fill, within
    ``FILL_TEXELS``), so that a drawn cell's corner beyond the ground shows ground, not grey.

    GDAL fills a texel from the texels within ``FILL_TEXELS`` of it alone, so only the window holding the holes
    near a hit, widened by that distance, is filled: the same colours (a leaf at the model's edge is mostly
    holes beyond reach, a leaf inside has a few along its seams)."""
    if hit.all() or not hit.any():
        return rgb
    reach = FILL_TEXELS
    (hole_rows, hole_cols), (hit_rows, hit_cols) = _extent(~hit), _extent(hit)
    rows = (max(hole_rows[0], hit_rows[0] - reach), min(hole_rows[1], hit_rows[1] + reach))
    cols = (max(hole_cols[0], hit_cols[0] - reach), min(hole_cols[1], hit_cols[1] + reach))
    if rows[0] >= rows[1] or cols[0] >= cols[1]:  # no hole within reach of a hit
        return rgb
    window = (slice(max(0, rows[0] - reach), rows[1] + reach), slice(max(0, cols[0] - reach), cols[1] + reach))
    mask = mem_raster(hit[window].astype(np.uint8)[None])
    bands = mem_raster(np.moveaxis(rgb[window], -1, 0))
    for band in range(3):
        fill_nodata(bands.GetRasterBand(band + 1), mask.GetRasterBand(1), reach)
    filled = rgb.copy()
    filled[window] = np.moveaxis(bands.ReadAsArray(), 0, -1)
    return filled


def _extent(mask: np.ndarray) -> tuple[tuple[int, int], tuple[int, int]]:
    """The rows [first, end) and columns [first, end) holding the True values of a 2D ``mask`` (some)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return (int(rows[0]), int(rows[-1]) + 1), (int(cols[0]), int(cols[-1]) + 1)


def neighbour_mean(grid: np.ndarray) -> np.ndarray:
    """Each cell's mean of its finite 8 neighbours (NaN where none is)."""
    padded = np.pad(grid, 1, constant_values=np.nan)
    rows, cols = grid.shape
    stack = np.stack([padded[1 + dy:1 + dy + rows, 1 + dx:1 + dx + cols]
                      for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx])
    finite = np.isfinite(stack)
    count = finite.sum(axis=0)
    total = np.where(finite, stack, 0.0).sum(axis=0)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def mem_raster(bands: np.ndarray, geotransform: tuple[float, ...] = (0.0, 1.0, 0.0, 0.0, 0.0, -1.0)) -> gdal.Dataset:
    """An in-memory raster of ``bands`` (bands, rows, columns), float64 or byte, without a CRS."""
    kind = gdal.GDT_Byte if bands.dtype == np.uint8 else gdal.GDT_Float64
    ds = gdal.GetDriverByName("MEM").Create("", bands.shape[2], bands.shape[1], bands.shape[0], kind)
    ds.SetGeoTransform(geotransform)
    for k, band in enumerate(bands):
        ds.GetRasterBand(k + 1).WriteArray(band)
        if kind == gdal.GDT_Float64:
            ds.GetRasterBand(k + 1).SetNoDataValue(float("nan"))
    return ds


def _mip_levels(triangles: TriangleRows, shapes: dict[int, tuple[int, ...]], step: float) -> dict[int, int]:
    """For each image number of ``shapes`` (its rows, columns): the mip level whose texels are nearest ``step``
    metres, by the median texel size over its triangles. The triangles' ground areas are computed once for all
    the images (a gather of each image's corners took a tenth of the leaves' coarse terrain)."""
    if not shapes:
        return {}
    ground = np.abs(_doubled_areas(triangles.xyz[:, :, :2]))
    levels = {}
    for number, shape in shapes.items():
        mine = np.flatnonzero(triangles.image == number)
        uv = np.take(triangles.uv, mine, axis=0).astype(np.float64) * [shape[1], shape[0]]
        texels = np.abs(_doubled_areas(uv))
        ok = texels > 0
        if not ok.any():
            levels[number] = 0
            continue
        texel = float(np.median(np.sqrt(ground[mine][ok] / texels[ok])))
        levels[number] = max(0, int(np.floor(np.log2(step / texel + 1e-9)))) if texel > 0 else 0
    return levels


def _doubled_areas(corners: np.ndarray) -> np.ndarray:
    """Twice the signed areas of 2D triangles (t, 3, 2): what ``np.cross`` gives for their edges, bit for bit,
    without its overhead per call (and its deprecation of 2D vectors in numpy 2)."""
    ax, ay = corners[:, 0, 0], corners[:, 0, 1]
    return (corners[:, 1, 0] - ax) * (corners[:, 2, 1] - ay) - (corners[:, 1, 1] - ay) * (corners[:, 2, 0] - ax)


def parent_patch(children: dict[tuple[int, int], Patch], cells: int, size: int) -> Patch:
    """Join four children's patches (key (dx, dy), dy = 1 the northern half) into their parent's."""
    half, half_size = cells // 2, size // 2
    heights = np.full((cells + 1, cells + 1), np.nan)
    image = np.full((size, size, 3), NO_COLOUR, dtype=np.uint8)
    covered = np.zeros((cells, cells), dtype=bool)
    for (dx, dy), child in children.items():
        r, c = (0 if dy else half), dx * half
        block = heights[r:r + half + 1, c:c + half + 1]
        np.copyto(block, child.heights[::2, ::2], where=np.isnan(block))
        if child.covered is not None:
            covered[r:r + half, c:c + half] = child.covered.reshape(half, 2, half, 2).any(axis=(1, 3))
        r, c = (0 if dy else half_size), dx * half_size
        pixels = child.image
        if len(pixels) != half_size:  # an upper tile's image; leaves sample theirs at half size directly
            pixels = pixels.astype(np.uint16)
            pixels = ((pixels[0::2, 0::2] + pixels[1::2, 0::2] + pixels[0::2, 1::2] + pixels[1::2, 1::2] + 2) // 4)
        image[r:r + half_size, c:c + half_size] = pixels
    error = 0.0
    for (dx, dy), child in children.items():
        r, c = (0 if dy else half), dx * half
        coarse = _bilinear_double(heights[r:r + half + 1, c:c + half + 1])
        deviation = np.abs(coarse - child.heights)
        if np.isfinite(deviation).any():
            error = max(error, float(np.nanmax(deviation)) + child.error)
        else:
            error = max(error, child.error)
    return Patch(fill_heights(heights, covered), image, error, covered)


def _bilinear_double(grid: np.ndarray) -> np.ndarray:
    """A (k + 1)² grid interpolated to (2k + 1)²: the points between vertices take their neighbours' mean."""
    k = grid.shape[0] - 1
    out = np.full((2 * k + 1, 2 * k + 1), np.nan)
    out[::2, ::2] = grid
    out[::2, 1::2] = (grid[:, :-1] + grid[:, 1:]) / 2
    out[1::2, ::2] = (grid[:-1, :] + grid[1:, :]) / 2
    out[1::2, 1::2] = (grid[:-1, :-1] + grid[1:, :-1] + grid[:-1, 1:] + grid[1:, 1:]) / 4
    return out


def grid_triangles(patch: Patch, rect: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The patch as triangles: model corners (t, 3, 3) and glTF uv (t, 3, 2) over its image: its covered cells
    (without ``covered``: the cells whose four corners have a height)."""
    n = patch.heights.shape[0] - 1
    xmin, _, xmax, ymax = rect
    step = (xmax - xmin) / n
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    points = np.stack([xmin + j * step, ymax - i * step, patch.heights], axis=-1)
    uv = np.stack([j / n, i / n], axis=-1)
    corner = {(a, b): (slice(a, n + a), slice(b, n + b)) for a in (0, 1) for b in (0, 1)}
    nw, ne, sw, se = (corner[0, 0], corner[0, 1], corner[1, 0], corner[1, 1])
    valid = np.isfinite(patch.heights)
    keep = (valid[nw] & valid[ne] & valid[sw] & valid[se]).ravel()
    if patch.covered is not None:
        keep &= patch.covered.ravel()
    orders = ((nw, sw, se), (nw, se, ne))
    quads = [np.stack([points[a].reshape(-1, 3) for a in order], axis=1)[keep] for order in orders]
    quad_uv = [np.stack([uv[a].reshape(-1, 2) for a in order], axis=1)[keep] for order in orders]
    return np.concatenate(quads), np.concatenate(quad_uv)
