"""The terrain mesh: triangulated with the constraints, refined until it fits the DEM.

Heights come from the DEM by bilinear interpolation (``dem.Dem``), and the mesh is refined until
no edge is longer than ``max_edge`` and the planar triangles stay within ``tolerance`` of the
interpolated DEM surface everywhere (``vertical_error``: a rigorous cheap bound settles most
triangles, the rest and the reported maximum are measured exactly). Refinement for edge length
re-meshes only patches around the few triangles that need it.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
import shapely
from osgeo import gdal, ogr, osr
from shapely.geometry.base import BaseGeometry

from ..infra.arrays import edge_pairs, ragged_indices, triangle_edge_keys
from ..infra.dem import Dem
from ..infra.deps import require
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.step_layers import TIN_SURFACES
from . import triangulators
from .constraints import MIN_WIDTH, Constraints, Feature, Seam, _classify, clean_constraints

ROUNDING = 1e-3  # m: the precision coordinates are written with


#: the first pass's triangles are about this × max_edge² (Triangle's area bound), for the size estimate
AREA_FACTOR = triangulators.AREA_FACTOR


#: refuse meshes that would not fit in memory on an ordinary machine
MAX_TRIANGLES = 30_000_000


@dataclass
class Tin:
    """The triangulated terrain: world coordinates, one label per triangle."""

    vertices: np.ndarray  # (n, 3)
    triangles: np.ndarray  # (m, 3), counter-clockwise seen from above
    surface: np.ndarray  # (m,) one of TIN_SURFACES
    feature_id: np.ndarray  # (m,) wit_id of the road / building, or None
    constraints: Constraints


@dataclass
class TinStats:
    """What the triangulation produced, for the log and the benchmark."""

    vertices: int
    triangles: int
    max_edge: float
    max_vertical_error: float
    refinement_iterations: int
    nodata_filled: int
    constraint_segments: int
    dropped_features: int
    triangles_by_surface: dict[str, int]

    def as_dict(self) -> dict:
        return asdict(self)


def _split_long_segments(vertices: np.ndarray, segments: np.ndarray,
                         max_edge: float) -> tuple[np.ndarray, np.ndarray]:
    """Subdivide segments longer than ``max_edge`` into equal pieces (new vertices appended)."""
    p, q = vertices[segments[:, 0]], vertices[segments[:, 1]]
    pieces = np.maximum(np.ceil(np.hypot(*(q - p).T) / max_edge - 1e-9), 1).astype(np.int64)
    owner, k = ragged_indices(pieces - 1)  # interior points of each segment
    t = ((k + 1) / pieces[owner])[:, None]
    new = p[owner] + t * (q[owner] - p[owner])
    ids = np.arange(len(vertices), len(vertices) + len(new))
    # chain of every segment: start, its interior points, end
    starts = np.cumsum(pieces) - pieces  # position of each segment's first piece
    chain_a = np.empty(pieces.sum(), dtype=np.int64)
    chain_b = np.empty(pieces.sum(), dtype=np.int64)
    chain_a[starts] = segments[:, 0]
    chain_b[starts + pieces - 1] = segments[:, 1]
    inner = starts[owner] + k
    chain_b[inner] = ids
    chain_a[inner + 1] = ids
    return np.vstack([vertices, new]), np.column_stack([chain_a, chain_b]).astype(np.int32)


def _split_for_dem(vertices: np.ndarray, segments: np.ndarray, dem: Dem, origin: np.ndarray, tolerance: float,
                   max_rounds: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Halve every segment along which the DEM leaves the straight line between its ends by more than
    ``tolerance`` (exactly, ``Dem.deviation_range``), until none does.

    A rule of the segment alone: two tiles that share a border segment split it alike, so with no
    Steiner point allowed on segments afterwards their meshes meet vertex for vertex.
    """
    world = vertices + origin
    z = dem.sample(world[:, 0], world[:, 1])
    for _ in range(max_rounds):
        p, q = segments[:, 0], segments[:, 1]
        low, high = dem.deviation_range(world[p, 0], world[p, 1], z[p], world[q, 0], world[q, 1], z[q],
                                        ends_on_surface=True)
        bad = np.maximum(-low, high) > tolerance
        if not bad.any():
            break
        mid = 0.5 * (vertices[p[bad]] + vertices[q[bad]])
        ids = np.arange(len(vertices), len(vertices) + len(mid))
        vertices = np.vstack([vertices, mid])
        world = np.vstack([world, mid + origin])
        z = np.concatenate([z, dem.sample(mid[:, 0] + origin[0], mid[:, 1] + origin[1])])
        segments = np.vstack([segments[~bad], np.column_stack([p[bad], ids]), np.column_stack([ids, q[bad]])])
    return vertices, segments.astype(np.int32)


def _triangle_areas(xy: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _longest_edges(xy: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    squared = [((q - p) ** 2).sum(axis=1) for p, q in ((a, b), (b, c), (c, a))]
    return np.sqrt(np.maximum(np.maximum(squared[0], squared[1]), squared[2]))


def _with_heights(dem: Dem, world: np.ndarray) -> np.ndarray:
    return np.column_stack([world, dem.sample(world[:, 0], world[:, 1])])


def vertical_error(dem: Dem, xyz: np.ndarray, tris: np.ndarray, tolerance: float = 0.0) -> np.ndarray:
    """Max |DEM − planar triangle| per triangle (vertex z must be DEM heights): exact wherever it
    exceeds ``tolerance`` (0: everywhere), elsewhere possibly an upper bound that is itself within
    ``tolerance``, so ``error > tolerance`` picks exactly the triangles that are too far off.

    Most triangles are settled by ``Dem.plane_deviation_bound``; only the rest are measured
    exactly (``exact_vertical_error``).
    """
    if not len(tris):
        return np.zeros(0)
    error = dem.plane_deviation_bound(xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]])
    over = np.flatnonzero(error > tolerance)
    error[over] = exact_vertical_error(dem, xyz, tris[over])
    return error


def max_vertical_error(dem: Dem, xyz: np.ndarray, tris: np.ndarray, error: np.ndarray, tolerance: float) -> float:
    """The exact maximum of ``error`` as ``vertical_error(…, tolerance)`` gave it (updated in place).

    The values above ``tolerance`` are exact; the largest bounds below are measured exactly in
    falling order until none can beat the largest exact value (by a nanometre).
    """
    slack = 1e-9  # m: rounding noise in the bounds costs nothing
    over = error > tolerance
    exact_max = float(error[over].max()) if over.any() else 0.0
    if not over.any() and len(error):  # a first guess from the largest bounds keeps the sort below short
        top = np.argpartition(-error, min(1024, len(error) - 1))[:1024]
        error[top] = exact_vertical_error(dem, xyz, tris[top])
        over[top] = True
        exact_max = float(error[top].max())
    rest = np.flatnonzero(~over & (error > exact_max + slack))
    rest = rest[np.argsort(-error[rest], kind="stable")]
    start, size = 0, 1024  # growing batches: few calls, little wasted work
    while start < len(rest) and error[rest[start]] > exact_max + slack:
        batch = rest[start:start + size]
        error[batch] = exact_vertical_error(dem, xyz, tris[batch])
        exact_max = max(exact_max, float(error[batch].max()))
        start, size = start + size, 2 * size
    return exact_max


def exact_vertical_error(dem: Dem, xyz: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Exact max |DEM − planar triangle| over each triangle (vertex z must be DEM heights).

    The difference of the piecewise bilinear DEM and a plane is bilinear inside each DEM cell,
    hence linear along the grid lines through the cell centres: its extremes over a triangle lie
    on the triangle's edges (``Dem.deviation_range``) or at the cell centres inside it.
    """
    if not len(tris):
        return np.zeros(0)
    unique, inverse = np.unique(triangle_edge_keys(tris), return_inverse=True)
    i, j = edge_pairs(unique).T
    lo, hi = dem.deviation_range(xyz[i, 0], xyz[i, 1], xyz[i, 2], xyz[j, 0], xyz[j, 1], xyz[j, 2],
                                 ends_on_surface=True)
    error = np.maximum(-lo, hi)[inverse.ravel()].reshape(-1, 3).max(axis=1)

    a, b, c = xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]]
    corners = np.stack([a, b, c])
    lower, upper = corners.min(axis=0), corners.max(axis=0)
    owner, x, y, z = dem.nodes_in_boxes(lower[:, 0], lower[:, 1], upper[:, 0], upper[:, 1])
    if len(owner):
        a, b, c = a[owner], b[owner], c[owner]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        with np.errstate(divide="ignore", invalid="ignore"):  # a sliver too thin for world coordinates
            wa = ((b[:, 0] - x) * (c[:, 1] - y) - (b[:, 1] - y) * (c[:, 0] - x)) / det
            wb = ((c[:, 0] - x) * (a[:, 1] - y) - (c[:, 1] - y) * (a[:, 0] - x)) / det
        wc = 1.0 - wa - wb
        inside = (wa >= -1e-12) & (wb >= -1e-12) & (wc >= -1e-12)
        dev = np.abs(z - (wa * a[:, 2] + wb * b[:, 2] + wc * c[:, 2]))
        np.maximum.at(error, owner[inside], dev[inside])
    return error


def triangulate(area: BaseGeometry, buildings: Sequence[Feature], roads: Sequence[Feature], dem: Dem,
                max_edge: float = triangulators.MAX_EDGE, tolerance: float = triangulators.VERTICAL_TOLERANCE,
                footprints_as_holes: bool = True, max_iterations: int = 10, fixed_segments: bool = False,
                seam: Seam | None = None,
                feedback: Feedback = SILENT, triangulator: int | None = None) -> tuple[Tin, TinStats]:
    """Mesh the area with footprints and roads as constraints, refined to ``max_edge`` and ``tolerance``.

    ``triangulator``: a ``triangulators.BACKENDS`` key (None: Triangle where installed, else CDT); the
    checks and the refinement they drive are the same whichever backend meshes.
    ``fixed_segments`` (tiles): every segment — the tile's border above all — is split beforehand by a
    rule of the segment alone (equal pieces ≤ ``max_edge``, then halved until the DEM is within
    ``tolerance`` along it) and no Steiner point may go on any segment, so neighbouring tiles share
    their border vertices exactly. A backend that never splits segments gets them split so always.
    """
    backend = triangulators.backend(triangulator)
    if not max_edge > 0 or not tolerance > 0:
        raise InputError("Max edge length and vertical tolerance must be positive.")
    require([backend.module])
    triangulators.announce(backend, feedback)
    feedback.progress(0)
    cons = clean_constraints(area, buildings, roads, footprints_as_holes, seam=seam)
    estimate = cons.area.area / (AREA_FACTOR * max_edge ** 2)
    if estimate > MAX_TRIANGLES:
        raise InputError(f"A max edge length of {max_edge} m would make about {estimate:,.0f} triangles over this "
                         "area; use a longer max edge or split the area into tiles.")
    if cons.dropped:
        feedback.warning(f"{cons.dropped} building/road polygon(s) dropped: empty, outside the area or slivers "
                         f"narrower than {MIN_WIDTH * 100:.0f} cm.")
    feedback.check_canceled()
    feedback.progress(10)

    if not len(cons.regions):
        raise InputError("Nothing is left to triangulate: building footprints cover the whole study area.")
    origin = np.array(cons.origin, dtype=np.float64)
    # tiles: the same pieces whichever backend meshes, so a resumed run's tiles meet those of an earlier one
    piece = min(b.piece_length for b in triangulators.BACKENDS) if fixed_segments else backend.piece_length
    # rounding to the millimetre before writing (snap_to_grid) lengthens an edge by up to 1.4 mm: the mesh keeps
    # 2 mm below the limit, so the written TIN is within it
    target = max_edge - 2 * ROUNDING if max_edge > 20 * ROUNDING else max_edge
    vertices, segments = _split_long_segments(cons.vertices, cons.segments, piece * target)
    fixed = fixed_segments or not backend.splits_segments
    if fixed:
        vertices, segments = _split_for_dem(vertices, segments, dem, origin, tolerance)
    pslg = triangulators.Pslg(vertices, segments, cons.holes, cons.regions, _face_locator(cons))
    mesh, fit, iterations = _refine(backend, pslg, dem, origin, target, max_edge, tolerance, fixed, max_iterations,
                                    feedback)
    xyz, tris, longest = fit.xyz, mesh.triangles, fit.longest
    max_error = max_vertical_error(dem, xyz, tris, fit.error, tolerance)
    too_long, too_far = fit.misfits(target, tolerance)
    if too_long.any() or too_far.any():
        feedback.warning(f"After {iterations} refinement passes the mesh still has edges up to {longest.max():.2f} m "
                         f"and a vertical error up to {max_error:.3f} m.")
    feedback.info(f"Mesh: longest edge {longest.max():.2f} m, max vertical error {max_error:.3f} m.")

    surface, feature = _labels(mesh.region, xyz, tris, cons)
    tin = Tin(xyz, tris, surface, feature, cons)
    counts = {name: int((surface == name).sum()) for name in TIN_SURFACES}
    used = int(np.count_nonzero(np.bincount(tris.ravel(), minlength=len(xyz))))  # some lie in holes
    stats = TinStats(vertices=used, triangles=len(tris), max_edge=float(longest.max()),
                     max_vertical_error=max_error, refinement_iterations=iterations,
                     nodata_filled=dem.nodata_cells, constraint_segments=len(cons.segments),
                     dropped_features=cons.dropped, triangles_by_surface=counts)
    feedback.progress(100)
    return tin, stats


@dataclass
class _Fit:
    """A mesh measured against the limits: its vertices with DEM heights, each triangle's longest edge and its
    distance from the DEM (``vertical_error``)."""

    xy: np.ndarray  # (n, 2) the mesh's vertices, origin-relative
    xyz: np.ndarray  # (n, 3) world coordinates
    longest: np.ndarray  # (m,)
    error: np.ndarray  # (m,)

    def misfits(self, target: float, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
        """(an edge over ``target``, farther than ``tolerance`` from the DEM) per triangle."""
        return self.longest > target * (1 + 1e-9), self.error > tolerance


def _measure(mesh: triangulators.Mesh, previous: _Fit | None, dem: Dem, origin: np.ndarray,
             tolerance: float) -> _Fit:
    """Take the mesh in: heights of its new vertices, length and DEM error of its new triangles.

    Refining keeps the vertices, and a backend that tells each triangle's row in the previous mesh
    (``Mesh.origin``) lets the unchanged triangles keep their measures: only the new ones are measured.
    """
    xy, tris = mesh.vertices, mesh.triangles
    known = len(previous.xy) if previous is not None and np.array_equal(xy[:len(previous.xy)], previous.xy) else 0
    xyz = _with_heights(dem, xy[known:] + origin)
    if previous is not None and known:
        xyz = np.vstack([previous.xyz[:known], xyz])
    if previous is None or mesh.origin is None or not known:
        return _Fit(xy, xyz, _longest_edges(xy, tris), vertical_error(dem, xyz, tris, tolerance))
    fresh = np.flatnonzero(mesh.origin < 0)
    longest, error = previous.longest[mesh.origin], previous.error[mesh.origin]
    longest[fresh] = _longest_edges(xy, tris[fresh])
    error[fresh] = vertical_error(dem, xyz, tris[fresh], tolerance)
    return _Fit(xy, xyz, longest, error)


def _area_limits(fit: _Fit, tris: np.ndarray, too_long: np.ndarray, too_far: np.ndarray, target: float,
                 tolerance: float) -> np.ndarray:
    """The largest area each triangle may have in the next pass (−1: as it is).

    A triangle too long shrinks to fit ``target``; the DEM error shrinks with the square of the size (the
    area), so one too far off shrinks by that, and at least by half.
    """
    shrink = np.ones(len(tris))
    shrink[too_long] = 0.9 * (target / fit.longest[too_long]) ** 2
    shrink[too_far] = np.minimum(shrink[too_far], np.clip(0.8 * tolerance / fit.error[too_far], 0.05, 0.5))
    bad = too_long | too_far
    limits = np.full(len(tris), -1.0)
    limits[bad] = shrink[bad] * _triangle_areas(fit.xy, tris[bad])
    return limits


def _refine(backend: triangulators.Triangulator, pslg: triangulators.Pslg, dem: Dem, origin: np.ndarray, target: float,
            max_edge: float, tolerance: float, fixed: bool, max_iterations: int,
            feedback: Feedback) -> tuple[triangulators.Mesh, _Fit, int]:
    """Mesh the PSLG, then refine until every triangle fits ``target`` and ``tolerance``, or ``max_iterations``
    passes, or no Steiner point can go where one is needed. Returns the mesh, its measures and the passes made.
    """
    mesh = backend.mesh(pslg, target, fixed)
    fit = _measure(mesh, None, dem, origin, tolerance)
    iterations = 0
    while True:
        too_long, too_far = fit.misfits(target, tolerance)
        feedback.info(f"Mesh pass {iterations}: {len(mesh.triangles)} triangles, {int(too_long.sum())} with an edge "
                      f"over {max_edge:g} m, {int(too_far.sum())} more than {tolerance:g} m off the DEM.")
        if not (too_long.any() or too_far.any()) or iterations == max_iterations:
            return mesh, fit, iterations
        feedback.check_canceled()
        feedback.progress(10 + 80 * (iterations + 1) / (max_iterations + 1))
        iterations += 1
        tris = mesh.triangles
        limits = _area_limits(fit, tris, too_long, too_far, target, tolerance)
        mesh = backend.refine(mesh, pslg, limits, fixed, whole=bool(too_far.any()))
        if len(mesh.triangles) == len(tris) and np.array_equal(mesh.triangles, tris):
            return mesh, fit, iterations  # no Steiner point could go where one is needed
        fit = _measure(mesh, fit, dem, origin, tolerance)


def _face_locator(cons: Constraints):
    """``Pslg.locate`` for the faces of ``cons``: the region row of each (origin-relative) point, −1 in a
    hole or outside the area, −2 in no face.

    Points at least ``clear`` from every segment (the CDT backend's lattice) are looked up in a raster of
    the faces with cells of ``clear`` / 0.75: the centre of a point's cell is then in the point's face,
    and GDAL burns a cell with the face its centre lies in. Other points: point in polygon.
    """
    region_row = np.where(cons.meshed, np.cumsum(cons.meshed) - 1, -1)
    faces = cons.faces.copy()
    shapely.prepare(faces)  # point in polygon on an edge index: the terrain face has thousands of holes
    tree = shapely.STRtree(faces)
    origin = np.array(cons.origin, dtype=np.float64)
    rasters: dict[float, tuple] = {}

    def exact(world: np.ndarray) -> np.ndarray:
        out = np.full(len(world), -2, dtype=np.int64)
        point, face = tree.query(shapely.points(world))  # boxes only, then the prepared polygons
        inside = shapely.contains_xy(faces[face], world[point, 0], world[point, 1])
        out[point[inside]] = region_row[face[inside]]
        return out

    def locate(points: np.ndarray, clear: float = 0.0) -> np.ndarray:
        if not len(points):
            return np.full(0, -2, dtype=np.int64)
        world = points + origin
        if clear <= 0:
            return exact(world)
        if clear not in rasters:
            rasters[clear] = _face_raster(faces, clear / 0.75)
        grid, x0, y0, cell = rasters[clear]
        if grid is None:
            return exact(world)
        col = np.floor((world[:, 0] - x0) / cell).astype(np.int64)
        row = np.floor((y0 - world[:, 1]) / cell).astype(np.int64)
        inside = (col >= 0) & (col < grid.shape[1]) & (row >= 0) & (row < grid.shape[0])
        out = np.full(len(world), -2, dtype=np.int64)
        face = grid[row[inside], col[inside]] - 1
        out[np.flatnonzero(inside)[face >= 0]] = region_row[face[face >= 0]]
        return out

    return locate


#: the face raster of ``_face_locator`` stays below this many cells (else point in polygon)
MAX_FACE_CELLS = 40_000_000


def _face_raster(faces: np.ndarray, cell: float) -> tuple:
    """(grid of face index + 1, 0 outside every face; x0; y0; cell) or (None, …) when too big."""
    xmin, ymin, xmax, ymax = shapely.total_bounds(faces)
    cols, rows = math.ceil((xmax - xmin) / cell) + 1, math.ceil((ymax - ymin) / cell) + 1
    if cols * rows > MAX_FACE_CELLS:
        return None, 0.0, 0.0, cell
    raster = gdal.GetDriverByName("MEM").Create("", cols, rows, 1, gdal.GDT_Int32)
    raster.SetGeoTransform((xmin, cell, 0.0, ymax, 0.0, -cell))
    frame = osr.SpatialReference()
    frame.SetLocalCS("faces")  # the same on both sides: no transformation
    raster.SetSpatialRef(frame)
    source = ogr.GetDriverByName("Memory").CreateDataSource("")
    layer = source.CreateLayer("faces", frame, geom_type=ogr.wkbPolygon)
    layer.CreateField(ogr.FieldDefn("id", ogr.OFTInteger))
    definition = layer.GetLayerDefn()
    for k, wkb in enumerate(shapely.to_wkb(faces)):
        feature = ogr.Feature(definition)
        feature.SetField(0, k + 1)
        feature.SetGeometry(ogr.CreateGeometryFromWkb(wkb))
        layer.CreateFeature(feature)
    gdal.RasterizeLayer(raster, [1], layer, options=["ATTRIBUTE=id"])
    return raster.GetRasterBand(1).ReadAsArray(), xmin, ymax, cell


def _areas_3d(xyz: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Area of each triangle in 3D."""
    a, b, c = xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def _labels(region: np.ndarray, xyz: np.ndarray, tris: np.ndarray,
            cons: Constraints) -> tuple[np.ndarray, np.ndarray]:
    """Surface name and feature id per triangle from its region (a row of ``cons.regions``, −1: none)."""
    unseeded = region < 0
    surface = np.empty(len(tris), dtype=object)
    feature = np.empty(len(tris), dtype=object)
    names = np.array(TIN_SURFACES, dtype=object)
    surface[~unseeded] = names[cons.region_surface[region[~unseeded]]]
    feature[~unseeded] = cons.region_feature[region[~unseeded]]
    if unseeded.any():  # a seed too close to a segment to be located; classify by centroid instead
        centroids = shapely.points(xyz[tris[unseeded]][:, :, :2].mean(axis=1))
        codes, ids = _classify(centroids, cons.footprints, cons.roads)
        surface[unseeded], feature[unseeded] = names[codes], ids
    return surface, feature
