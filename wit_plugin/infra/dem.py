"""Read a DEM window and interpolate heights bilinearly between cell centres.

The terrain TIN and the building bases both take their Z from here, so they agree exactly.
Cells that hold NoData (the declared value, else anything ≤ −1000 because real files such as the
Seoul 90 m DEM store −9999 without declaring it) are filled from their neighbours before any
interpolation: a −9999 never leaks into a height.

Inside a cell the bilinear surface is a quadratic along any straight segment, and it is linear
along the grid lines through the cell centres; ``deviation_range`` uses this to find the exact
extremes of the surface along segments, which the refinement (terrain) and the minimum base
height (extrude) rely on instead of guessing from a few samples.

A DEM in another CRS than the layers' is reprojected on the fly, window by window, onto a grid of
its own cell size in the layers' CRS (bilinear, ``Dem._open_reprojected``); the surface sampled,
and the one the terrain's tolerance is measured against, is then the bilinear surface of that grid.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import gdal

from .arrays import ragged_indices
from .errors import InputError
from .feedback import SILENT, Feedback
from .io.raster_io import fill_nodata, open_raster, read_window
from .raster_crs import (
    aligned,
    cell_size,
    crs_code,
    crs_name,
    foreign_crs,
    raster_crs,
    raster_extent,
    transform_geometry,
    warp,
)

#: values at or below this are NoData in files that declare no NoData value (real DEMs store −9999 so)
NODATA_THRESHOLD = -1000.0

Bounds = tuple[float, float, float, float]  # xmin, ymin, xmax, ymax


class Dem:
    """A north-up grid of heights with NoData filled, sampled bilinearly between cell centres.

    ``values`` row 0 is the row at ``y0`` (GDAL order). ``open_edges`` says, for the
    (left, right, top, bottom) side, whether the grid continues beyond the array (a window of a
    bigger file): there the usable area stops at the outermost cell centres; at a real edge of
    the raster it reaches the raster edge, holding the outermost centre's value across the last
    half cell.
    """

    def __init__(self, values: np.ndarray, geotransform: tuple[float, ...], nodata: float | None = None,
                 open_edges: tuple[bool, bool, bool, bool] = (False, False, False, False),
                 feedback: Feedback = SILENT):
        x0, dx, rx, y0, ry, dy = (float(v) for v in geotransform)
        if rx != 0.0 or ry != 0.0 or dx == 0.0 or dy == 0.0:
            raise InputError("The DEM is rotated or has a zero cell size; warp it to a north-up grid first "
                             "(Raster ▸ Projections ▸ Warp).")
        grid = np.array(values, dtype=np.float64)
        if grid.ndim != 2 or grid.size == 0:
            raise InputError("The DEM window is empty.")
        missing = ~np.isfinite(grid)
        missing |= (grid == nodata) if nodata is not None else (grid <= NODATA_THRESHOLD)
        self.nodata_cells = int(missing.sum())
        if self.nodata_cells == grid.size:
            raise InputError("The DEM holds only NoData in the area needed; check that it covers the study area.")
        if self.nodata_cells:
            grid = _fill_from_neighbours(grid, missing)
            feedback.info(f"DEM: {self.nodata_cells} NoData cell(s) filled from their neighbours.")
        self.values = grid
        self.geotransform = (x0, dx, 0.0, y0, 0.0, dy)
        rows, cols = grid.shape
        left, right, top, bottom = open_edges
        # usable range in fractional cell-centre indices (u along columns, v along rows)
        self._u_range = (0.0 if left else -0.5, cols - 1.0 if right else cols - 0.5)
        self._v_range = (0.0 if top else -0.5, rows - 1.0 if bottom else rows - 0.5)

    @classmethod
    def open(cls, path: str | Path, bounds: Bounds | None = None, margin_cells: int = 4,
             feedback: Feedback = SILENT, crs: str | pyproj.CRS | None = None) -> Dem:
        """Band 1 of ``path``: only the window covering ``bounds`` (plus a margin), else all.

        ``crs``: the layers' CRS, in which ``bounds`` are given and the heights are sampled. A DEM in
        another CRS is reprojected on the fly (``_open_reprojected``); one without a CRS is taken to
        be in ``crs``, with a warning. Raises ``InputError`` if the file cannot be read or does not
        cover ``bounds``.
        """
        ds = open_raster(path, "DEM")
        source = reprojection(path, ds, crs, feedback)
        if source is not None:
            return cls._open_reprojected(ds, path, source, pyproj.CRS.from_user_input(crs), bounds, margin_cells,
                                         feedback)
        band = ds.GetRasterBand(1)
        gt = ds.GetGeoTransform()
        cols, rows = ds.RasterXSize, ds.RasterYSize
        c0, r0, c1, r1 = 0, 0, cols, rows
        if bounds is not None:
            ext = raster_extent(gt, cols, rows)
            short = _short_of(ext, bounds)
            if short:
                raise InputError(
                    f"The DEM {Path(path).name} (extent {_fmt(ext)}) does not cover the area needed "
                    f"({_fmt(bounds)}): it stops short by {shortfall(short)}. Use a DEM that covers the study area.")
            c0, r0, c1, r1 = _window(gt, cols, rows, bounds, margin_cells)
        data = read_window(band, c0, r0, c1 - c0, r1 - r0, f"the DEM {path}")
        window_gt = (gt[0] + c0 * gt[1], gt[1], gt[2], gt[3] + r0 * gt[5], gt[4], gt[5])
        return cls(data, window_gt, band.GetNoDataValue(),
                   open_edges=(c0 > 0, c1 < cols, r0 > 0, r1 < rows), feedback=feedback)

    @classmethod
    def _open_reprojected(cls, ds: gdal.Dataset, path: str | Path, source: pyproj.CRS, target: pyproj.CRS,
                          bounds: Bounds | None, margin_cells: int, feedback: Feedback) -> Dem:
        """The DEM reprojected to ``target`` over ``bounds``: a grid of the DEM's cell size in metres, aligned
        on its multiples (so tiles share it), whose every cell centre is the bilinear height of the source
        DEM at that point (GDAL's warper, each centre transformed exactly by PROJ, four source cells). The
        source window's NoData is filled first, as in the DEM's own CRS; heights are not changed (the
        DEM's vertical datum is left alone); nothing is written to disk."""
        name = Path(path).name
        gt = ds.GetGeoTransform()
        cols, rows = ds.RasterXSize, ds.RasterYSize
        extent = raster_extent(gt, cols, rows)
        size = cell_size(ds, source, target)
        if bounds is None:
            bounds = transform_geometry(shapely.box(*extent), source, target).bounds
        else:
            needed = transform_geometry(shapely.box(*bounds), target, source).bounds
            short = _short_of(extent, needed)
            if short:
                degrees = source.is_geographic
                raise InputError(
                    f"The DEM {name} (extent {_fmt(extent, degrees)} in {crs_code(source)}) does not cover the area "
                    f"needed ({_fmt(bounds)} in {crs_code(target)}, {_fmt(needed, degrees)} in the DEM's CRS): it "
                    f"stops short by {shortfall(short, degrees)}. Use a DEM that covers the study area.")
        grid = aligned(bounds, size, margin_cells)
        x0, y1 = grid[0], grid[3]
        reach = transform_geometry(shapely.box(*grid), target, source, size).bounds
        c0, r0, c1, r1 = _window(gt, cols, rows, reach, 2)
        if c1 <= c0 or r1 <= r0:
            raise InputError(f"The DEM {name} does not meet the area needed ({_fmt(bounds)} in {crs_code(target)}).")
        band = ds.GetRasterBand(1)
        window_gt = (gt[0] + c0 * gt[1], gt[1], 0.0, gt[3] + r0 * gt[5], 0.0, gt[5])
        filled = cls(read_window(band, c0, r0, c1 - c0, r1 - r0, f"the DEM {path}"), window_gt,
                     band.GetNoDataValue(), feedback=feedback)
        mem = gdal.GetDriverByName("MEM").Create("", c1 - c0, r1 - r0, 1, gdal.GDT_Float64)
        mem.SetGeoTransform(window_gt)
        mem.SetProjection(source.to_wkt())
        mem.GetRasterBand(1).WriteArray(filled.values)
        warped = warp(mem, source, target, grid, size, output_type=gdal.GDT_Float64, nodata=math.nan)
        values = read_window(warped, 0, 0, warped.RasterXSize, warped.RasterYSize, f"the DEM {path} reprojected")
        beyond = ~np.isfinite(values)  # cells whose centre lies past the DEM's edge (in the margin)
        if beyond.all():
            raise InputError(f"The DEM {name} does not meet the area needed ({_fmt(bounds)} in {crs_code(target)}).")
        if beyond.any():
            values = _fill_from_neighbours(values, beyond)
        dem = cls(values, (x0, size, 0.0, y1, 0.0, -size), math.nan, open_edges=(True, True, True, True))
        dem.nodata_cells = filled.nodata_cells  # the source's cells, as counted in its CRS
        return dem

    @property
    def extent(self) -> Bounds:
        """The area where ``sample`` answers: xmin, ymin, xmax, ymax."""
        x0, dx, _, y0, _, dy = self.geotransform
        xs = [x0 + (u + 0.5) * dx for u in self._u_range]
        ys = [y0 + (v + 0.5) * dy for v in self._v_range]
        return min(xs), min(ys), max(xs), max(ys)

    def _indices(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Fractional cell-centre indices (u, v) of points, checked to lie in the usable area."""
        x0, dx, _, y0, _, dy = self.geotransform
        u = (np.asarray(x, dtype=np.float64) - x0) / dx - 0.5
        v = (np.asarray(y, dtype=np.float64) - y0) / dy - 0.5
        eps = 1e-9
        bad = ~((u >= self._u_range[0] - eps) & (u <= self._u_range[1] + eps)
                & (v >= self._v_range[0] - eps) & (v <= self._v_range[1] + eps))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            px, py = (np.broadcast_to(a, u.shape).ravel()[k] for a in (x, y))
            raise InputError(f"{int(bad.sum())} point(s) lie outside the DEM (usable extent {_fmt(self.extent)}), "
                             f"e.g. ({px:.3f}, {py:.3f}). Use a DEM that covers the study area.")
        return u, v

    def sample(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bilinear height at each (x, y) from the four surrounding cell centres."""
        u, v = self._indices(x, y)
        rows, cols = self.values.shape
        u = np.clip(u, 0.0, cols - 1.0)
        v = np.clip(v, 0.0, rows - 1.0)
        j0 = np.minimum(np.floor(u), max(cols - 2, 0)).astype(np.intp)
        i0 = np.minimum(np.floor(v), max(rows - 2, 0)).astype(np.intp)
        alpha, beta = u - j0, v - i0
        dj = 1 if cols > 1 else 0
        di = cols if rows > 1 else 0
        flat = self.values.ravel()
        k = i0 * cols + j0
        f11, f21, f12, f22 = flat[k], flat[k + dj], flat[k + di], flat[k + di + dj]
        return (f11 * (1 - alpha) * (1 - beta) + f21 * alpha * (1 - beta)
                + f12 * (1 - alpha) * beta + f22 * alpha * beta)

    def nodes_in_boxes(self, xmin: np.ndarray, ymin: np.ndarray, xmax: np.ndarray, ymax: np.ndarray,
                       covering: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cell centres inside each box: (box index, x, y, height), concatenated over the boxes.

        ``covering``: also the centres just outside, so that the interpolation cells spanned by
        the returned centres cover the whole box (every box then gets at least one).
        """
        x0, dx, _, y0, _, dy = self.geotransform
        rows, cols = self.values.shape
        ua, ub = (np.asarray(xmin, float) - x0) / dx - 0.5, (np.asarray(xmax, float) - x0) / dx - 0.5
        va, vb = (np.asarray(ymin, float) - y0) / dy - 0.5, (np.asarray(ymax, float) - y0) / dy - 0.5
        if covering:
            j_lo = np.clip(np.floor(np.minimum(ua, ub)), 0, cols - 1).astype(np.int64)
            j_hi = np.clip(np.ceil(np.maximum(ua, ub)), 0, cols - 1).astype(np.int64)
            i_lo = np.clip(np.floor(np.minimum(va, vb)), 0, rows - 1).astype(np.int64)
            i_hi = np.clip(np.ceil(np.maximum(va, vb)), 0, rows - 1).astype(np.int64)
        else:
            j_lo = np.maximum(np.ceil(np.minimum(ua, ub)), 0).astype(np.int64)
            j_hi = np.minimum(np.floor(np.maximum(ua, ub)), cols - 1).astype(np.int64)
            i_lo = np.maximum(np.ceil(np.minimum(va, vb)), 0).astype(np.int64)
            i_hi = np.minimum(np.floor(np.maximum(va, vb)), rows - 1).astype(np.int64)
        nj = np.maximum(j_hi - j_lo + 1, 0)
        ni = np.maximum(i_hi - i_lo + 1, 0)
        owner, k = ragged_indices(nj * ni)
        j = j_lo[owner] + k % np.maximum(nj[owner], 1)
        i = i_lo[owner] + k // np.maximum(nj[owner], 1)
        return owner, x0 + (j + 0.5) * dx, y0 + (i + 0.5) * dy, self.values[i, j]

    def plane_deviation_bound(self, a: np.ndarray, b: np.ndarray, c: np.ndarray,
                              chunk: int = 65536) -> np.ndarray:
        """An upper bound of max |DEM − plane through a, b, c| over each triangle abc, cheap to get.

        Inside each interpolation cell the DEM minus a plane is bilinear, so its extremes over the
        cell are at the cell's corners: the largest |corner height − plane| over the cells covering
        the triangle's bounding box bounds it (rigorously; usually within a few times the exact
        value). Triangles reaching beyond the outermost cell centres, where the surface is held
        flat, and degenerate triangles get infinity: measure those exactly. Works in chunks of
        triangles so that the per-node arrays stay small.
        """
        bound = np.empty(len(a))
        for lo in range(0, len(a), chunk):
            pa, pb, pc = a[lo:lo + chunk], b[lo:lo + chunk], c[lo:lo + chunk]
            lower = np.minimum(np.minimum(pa, pb), pc)
            upper = np.maximum(np.maximum(pa, pb), pc)
            e1, e2 = pb - pa, pc - pa
            det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):  # plane z = za + gx·(x − xa) + gy·(y − ya)
                gx = (e1[:, 2] * e2[:, 1] - e2[:, 2] * e1[:, 1]) / det
                gy = (e2[:, 2] * e1[:, 0] - e1[:, 2] * e2[:, 0]) / det
            bound[lo:lo + chunk] = self._window_deviation(pa, gx, gy, lower, upper)
        return bound

    def _window_deviation(self, a: np.ndarray, gx: np.ndarray, gy: np.ndarray, lower: np.ndarray,
                          upper: np.ndarray) -> np.ndarray:
        """Max |height − plane| over the cell centres covering each box (``plane_deviation_bound``);
        infinity for boxes reaching beyond the outermost centres and for degenerate planes.

        Boxes spanning at most 3 × 3 centres (triangles no bigger than the cells, the usual case)
        take nine whole-array passes; the others go through ``nodes_in_boxes``.
        """
        x0, dx, _, y0, _, dy = self.geotransform
        rows, cols = self.values.shape
        u = (np.stack([lower[:, 0], upper[:, 0]]) - x0) / dx - 0.5
        v = (np.stack([lower[:, 1], upper[:, 1]]) - y0) / dy - 0.5  # dy < 0: upper y gives the lower row
        j_lo = np.clip(np.floor(u.min(axis=0)), 0, cols - 1).astype(np.int64)
        j_hi = np.clip(np.ceil(u.max(axis=0)), 0, cols - 1).astype(np.int64)
        i_lo = np.clip(np.floor(v.min(axis=0)), 0, rows - 1).astype(np.int64)
        i_hi = np.clip(np.ceil(v.max(axis=0)), 0, rows - 1).astype(np.int64)
        flat = self.values.ravel()
        out = np.zeros(len(a))
        with np.errstate(invalid="ignore"):
            for di in range(3):
                i = np.minimum(i_lo + di, i_hi)  # repeats the last centre: harmless for a maximum
                y = y0 + (i + 0.5) * dy - a[:, 1]
                for dj in range(3):
                    j = np.minimum(j_lo + dj, j_hi)
                    x = x0 + (j + 0.5) * dx - a[:, 0]
                    out = np.fmax(out, np.abs(flat[i * cols + j] - a[:, 2] - gx * x - gy * y))
            out[~np.isfinite(gx) | ~np.isfinite(gy)] = np.inf
            big = np.flatnonzero((j_hi - j_lo > 2) | (i_hi - i_lo > 2))
            if len(big):
                owner, x, y, z = self.nodes_in_boxes(lower[big, 0], lower[big, 1], upper[big, 0], upper[big, 1],
                                                     covering=True)
                k = big[owner]
                dev = np.abs(z - a[k, 2] - gx[k] * (x - a[k, 0]) - gy[k] * (y - a[k, 1]))
                dev[np.isnan(dev)] = np.inf
                out[big] = np.maximum.reduceat(dev, np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]]))
        beyond = (u.min(axis=0) < 0) | (u.max(axis=0) > cols - 1) | (v.min(axis=0) < 0) | (v.max(axis=0) > rows - 1)
        out[beyond] = np.inf  # past the outermost centres the surface is held flat: not bilinear
        return out

    def deviation_range(self, x0: np.ndarray, y0: np.ndarray, z0: np.ndarray, x1: np.ndarray, y1: np.ndarray,
                        z1: np.ndarray, ends_on_surface: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Exact min and max, along each segment, of (DEM height − the straight line z0→z1).

        Between the crossings of cell-centre grid lines the bilinear surface is a quadratic in
        the segment parameter, so its extremes are at the crossings, the ends, or the vertex of
        the parabola through each piece's ends and midpoint. ``ends_on_surface``: z0 and z1 are
        the DEM heights at the ends (TIN vertices), so the deviation there is 0 without sampling.
        """
        x0, y0, z0, x1, y1, z1 = (np.asarray(a, dtype=np.float64).ravel() for a in (x0, y0, z0, x1, y1, z1))
        ua, va = self._indices(x0, y0)
        ub, vb = self._indices(x1, y1)
        seg_u, t_u = _crossings(ua, ub)
        seg_v, t_v = _crossings(va, vb)
        n = len(x0)
        seg = np.concatenate([np.arange(n), np.arange(n), seg_u, seg_v])
        t = np.concatenate([np.zeros(n), np.ones(n), t_u, t_v])
        is_end = np.arange(len(t)) < 2 * n
        order = np.argsort(seg * 2.0 + t)  # by segment, then parameter (t ∈ [0, 1])
        seg, t, is_end = seg[order], t[order], is_end[order]

        def dev(s: np.ndarray, tt: np.ndarray) -> np.ndarray:
            return (self.sample(x0[s] + tt * (x1[s] - x0[s]), y0[s] + tt * (y1[s] - y0[s]))
                    - (z0[s] + tt * (z1[s] - z0[s])))

        g = np.zeros(len(t))
        sampled = ~is_end if ends_on_surface else np.ones(len(t), dtype=bool)
        g[sampled] = dev(seg[sampled], t[sampled])
        piece = np.flatnonzero(seg[1:] == seg[:-1])  # piece k runs from breakpoint k to k + 1
        s = seg[piece]
        ga, gb = g[piece], g[piece + 1]
        gm = dev(s, 0.5 * (t[piece] + t[piece + 1]))
        b = -3 * ga + 4 * gm - gb  # q(r) = ga + b r + c r², r ∈ [0, 1] along the piece
        c = 2 * ga - 4 * gm + 2 * gb
        with np.errstate(divide="ignore", invalid="ignore"):
            r = -b / (2 * c)
        r = np.where((c != 0) & (r > 0) & (r < 1), r, 0.0)
        gv = ga + b * r + c * r * r
        lo = np.minimum(np.minimum(ga, gb), gv)
        hi = np.maximum(np.maximum(ga, gb), gv)
        starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        return np.minimum.reduceat(lo, starts), np.maximum.reduceat(hi, starts)


def reprojection(path: str | Path, ds: gdal.Dataset, crs: str | pyproj.CRS | None,
                 feedback: Feedback = SILENT) -> pyproj.CRS | None:
    """The DEM's own CRS when it is another than the layers' ``crs`` and must be reprojected on the fly (said
    so, with the cell size it gets); None when it is in ``crs`` (or there is no ``crs`` to compare with). A DEM
    without a CRS is taken to be in ``crs``, with a warning that says so. Every reader of a DEM asks here, so
    a step run alone tells what the chain tells."""
    if not crs:
        return None  # the layers have no CRS: nothing to compare with
    if raster_crs(ds) is None:
        feedback.warning(f"The DEM {Path(path).name} has no coordinate reference system: it is assumed to be in the "
                         f"layers' CRS, {crs_name(pyproj.CRS.from_user_input(crs))}. If it is not, assign its CRS "
                         "first (Raster ▸ Projections ▸ Assign Projection).")
        return None
    source = foreign_crs(ds, crs)
    if source is not None:
        target = pyproj.CRS.from_user_input(crs)
        feedback.info(f"The DEM {Path(path).name} is in {crs_name(source)}: it is reprojected on the fly to "
                      f"{crs_name(target)} (bilinear, cells of {cell_size(ds, source, target):g} m).")
    return source


def _short_of(extent: Bounds, needed: Bounds) -> dict[str, float]:
    """By how much (CRS units) ``extent`` falls short of ``needed`` on each side that it does."""
    beyond = {"west": extent[0] - needed[0], "south": extent[1] - needed[1], "east": needed[2] - extent[2],
              "north": needed[3] - extent[3]}
    return {side: amount for side, amount in beyond.items() if amount > 0}


def shortfall(short: dict[str, float], degrees: bool = False) -> str:
    """e.g. "12.5 m to the east" or "0.001234° to the north, 0.000500° to the west"."""
    return ", ".join(f"{amount:,.6f}° to the {side}" if degrees else f"{amount:,.1f} m to the {side}"
                     for side, amount in short.items())


def _window(gt: tuple[float, ...], cols: int, rows: int, bounds: Bounds,
            margin_cells: int) -> tuple[int, int, int, int]:
    """The cells (c0, r0, c1, r1; ends excluded) covering ``bounds`` plus a margin, within the raster."""
    us = [(x - gt[0]) / gt[1] for x in (bounds[0], bounds[2])]
    vs = [(y - gt[3]) / gt[5] for y in (bounds[1], bounds[3])]
    c0 = max(0, math.floor(min(us)) - margin_cells)
    c1 = min(cols, math.ceil(max(us)) + margin_cells)
    r0 = max(0, math.floor(min(vs)) - margin_cells)
    r1 = min(rows, math.ceil(max(vs)) + margin_cells)
    return c0, r0, c1, r1


def _fmt(b: Bounds, degrees: bool = False) -> str:
    d = 6 if degrees else 1
    return f"x {b[0]:.{d}f}–{b[2]:.{d}f}, y {b[1]:.{d}f}–{b[3]:.{d}f}"


def _crossings(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each segment from index a to b crosses an integer: (segment, parameter in (0, 1))."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    first = np.floor(lo) + 1
    counts = np.maximum(np.ceil(hi) - first, 0).astype(np.int64)
    seg, k = ragged_indices(counts)
    return seg, (first[seg] + k - a[seg]) / (b[seg] - a[seg])


def _fill_from_neighbours(grid: np.ndarray, missing: np.ndarray) -> np.ndarray:
    """Fill the ``missing`` cells by inverse-distance weighting of the nearest valid cells (GDAL)."""
    rows, cols = grid.shape
    mem = gdal.GetDriverByName("MEM")
    data_ds = mem.Create("", cols, rows, 1, gdal.GDT_Float64)
    mask_ds = mem.Create("", cols, rows, 1, gdal.GDT_Byte)
    data_band, mask_band = data_ds.GetRasterBand(1), mask_ds.GetRasterBand(1)
    data_band.WriteArray(np.where(missing, 0.0, grid))
    mask_band.WriteArray((~missing).astype(np.uint8))
    fill_nodata(data_band, mask_band, max(rows, cols) + 1)
    return read_window(data_band, 0, 0, cols, rows, "the filled DEM (in memory)").astype(np.float64)
