"""Constrained Delaunay triangulation backends behind one small interface (wit:triangulateterrain).

Two libraries can mesh the terrain; the user picks one with the ``TRIANGULATOR`` parameter:

* 0 — ``triangle``: J. R. Shewchuk's Triangle, free for non-commercial use only. Its own quality and
  area switches refine the mesh.
* 1 — ``pythoncdt``: A. Amirkhanov's CDT, MPL-2.0 (usable in commercial work). It only triangulates:
  the Steiner points that make triangles small enough are ours (``wit_plugin.terrain.steiner``), and so is
  telling holes from regions (a flood fill across the edges that are not constraints).

Both take the same planar straight-line graph (``Pslg``: noded constraint segments, hole and region
seeds) and give the same ``Mesh``: the input vertices first and in their order, counter-clockwise
triangles, each with the region it lies in, and the constraint pieces (a segment split by a Steiner
point is recorded as its pieces). The terrain module above them checks every guarantee (edge length,
vertical tolerance, constraints present) the same way whichever backend ran.
"""
from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..infra.arrays import edge_keys, edge_pairs, triangle_edge_keys
from ..infra.deps import require
from ..infra.feedback import Feedback
from . import steiner

#: Triangle's minimum angle (degrees). Kept tiny on purpose: what matters is that with any "q"
#: Triangle keeps new vertices off constraint segments (its encroachment lens, here ~0.4 % of a
#: segment's length wide), whereas without it refinement can put a vertex a rounding error away
#: from a segment (a degenerate sliver, then duplicate vertices in the next pass). Larger angles
#: cost a lot: 5° more than doubles the triangles of the 1 km demo, and thin faces such as
#: digitising gaps between buildings fill with tiny triangles.
MIN_ANGLE = 0.5
#: Triangle's first-pass area bound as a fraction of max_edge²: √3/4 ≈ 0.43 would fit an equilateral
#: triangle, but Delaunay triangles of that area often have a longer edge (~40 % of them on a plain disc).
#: At 0.25 well under 1 % do and one refinement pass fixes them; 0.3 needs two passes and ends
#: with more triangles (measured on the 1 km demo, 5 m edges)
AREA_FACTOR = 0.25
#: the terrain mesh's targets, the defaults of wit:triangulateterrain and of the chain: the longest
#: triangle edge (m) and the largest height difference between the TIN and the DEM (m)
MAX_EDGE = 5.0
VERTICAL_TOLERANCE = 0.5


@dataclass
class Pslg:
    """A planar straight-line graph, coordinates relative to an origin near them (better conditioning).

    ``locate(points, clear)`` gives, for points, the row of ``regions`` whose face holds them, −1 in a hole
    or outside the area, −2 in no face at all (a sliver lost to snapping): backends that label triangles by
    where they lie rather than by flood fill from the seeds use it. ``clear`` > 0 promises that no point is
    nearer than that to a segment (a coarser, faster answer is then exact).
    """

    vertices: np.ndarray  # (n, 2)
    segments: np.ndarray  # (m, 2) vertex indices: noded, no crossings, no duplicates
    holes: np.ndarray  # (h, 2) one point inside each face that is not meshed
    regions: np.ndarray  # (r, 2) one point inside each meshed face
    locate: Callable[..., np.ndarray]
    _grid: steiner.SegmentGrid | None = field(default=None, repr=False)

    def segment_grid(self, reach: float) -> steiner.SegmentGrid:
        """An index of the segments for searches within ``reach`` (built again only for a longer reach)."""
        if self._grid is None or self._grid.cell < reach:
            self._grid = steiner.SegmentGrid(self.vertices[self.segments[:, 0]], self.vertices[self.segments[:, 1]],
                                             2.0 ** math.ceil(math.log2(max(reach, 1e-3))))
        return self._grid


@dataclass
class Mesh:
    """A triangulation of a ``Pslg``: its vertices first (same order), then the Steiner points."""

    vertices: np.ndarray  # (n, 2)
    triangles: np.ndarray  # (m, 3) counter-clockwise
    region: np.ndarray  # (m,) row of Pslg.regions, −1 where no seed says (labelled by position later)
    constrained: np.ndarray  # sorted unique edge keys (``edge_keys``) of the constraint pieces
    neighbours: np.ndarray | None = None  # (m, 3) edge neighbours (−1: none), when the backend gives them
    origin: np.ndarray | None = None  # (m,) each triangle's row in the previous mesh if unchanged, else −1
    state: Any = None  # the backend's own (CDT: the live triangulation, to insert more points into)


class Triangulator:
    """The interface: ``triangulate`` (constrained Delaunay, no refinement) is the library's; ``mesh`` and
    ``refine`` (Steiner points until triangles are small enough) are ours unless the library has its own."""

    key: int  # the TRIANGULATOR option
    label: str  # as the user sees it
    licence: str
    module: str  # the import name of the library
    #: the backend may put Steiner points on constraint segments while refining (recording the pieces);
    #: without, the terrain splits segments for the DEM beforehand
    splits_segments = False
    #: constraint segments are split beforehand into pieces of at most this × the maximum edge length
    piece_length = 1.0

    def triangulate(self, pslg: Pslg, points: np.ndarray | None = None,
                    regions: np.ndarray | None = None) -> Mesh:
        """The constrained Delaunay triangulation of ``pslg`` plus the Steiner ``points`` (none on a segment;
        ``regions``: the region row each lies in, when known), outside and holes removed."""
        raise NotImplementedError

    def insert(self, mesh: Mesh, pslg: Pslg, points: np.ndarray, regions: np.ndarray) -> Mesh:
        """``mesh`` with more Steiner ``points`` (as in ``triangulate``)."""
        raise NotImplementedError

    def mesh(self, pslg: Pslg, max_edge: float, fixed: bool) -> Mesh:
        """A first mesh aiming at edges of at most ``max_edge`` (ours: a lattice, then the edges still too
        long halved; see ``steiner``)."""
        points, regions = steiner.lattice_points(pslg, max_edge)
        return steiner.halve_long_edges(self, self.triangulate(pslg, points, regions), pslg, max_edge)

    def refine(self, mesh: Mesh, pslg: Pslg, limits: np.ndarray, fixed: bool, whole: bool) -> Mesh:
        """``mesh`` refined until every triangle with a positive limit is at most that area (or no Steiner
        point can go where one is needed without making a sliver). ``whole``: the library may re-mesh
        everything rather than patches (ours always inserts points into the mesh as it is)."""
        return steiner.refine(self, mesh, pslg, limits)


class TriangleBackend(Triangulator):
    key, label, module = 0, "Triangle (non-commercial licence)", "triangle"
    licence = "free for non-commercial use only (J. R. Shewchuk's licence)"
    splits_segments = True

    def _lib(self):
        require([self.module])
        import triangle  # optional dependency: the plugin loads without it

        return triangle

    @staticmethod
    def _mesh(out: dict, kept: np.ndarray | None = None) -> Mesh:
        # every call asks for the edges ("e"): Triangle leaves them out only when it made no triangle, and then
        # out["triangles"] below fails as before whatever this is
        constrained = (np.unique(edge_keys(out["edges"][out["edge_markers"].ravel() == 1])) if "edges" in out
                       else np.empty(0, dtype=np.int64))
        return Mesh(out["vertices"], out["triangles"], np.rint(out["triangle_attributes"][:, 0]).astype(np.int64) - 1,
                    constrained, out.get("neighbors"), kept)

    @staticmethod
    def _input(pslg: Pslg, points: np.ndarray | None = None, max_area: float = -1.0) -> dict:
        vertices = pslg.vertices if points is None or not len(points) else np.vstack([pslg.vertices, points])
        regions = np.column_stack([pslg.regions, np.arange(1, len(pslg.regions) + 1),
                                   np.full(len(pslg.regions), max_area)])
        data = {"vertices": vertices, "segments": pslg.segments, "regions": regions,
                "segment_markers": np.ones(len(pslg.segments), dtype=np.int32)}
        if len(pslg.holes):
            data["holes"] = pslg.holes
        return data

    def triangulate(self, pslg: Pslg, points: np.ndarray | None = None,
                    regions: np.ndarray | None = None) -> Mesh:
        return self._mesh(self._lib().triangulate(self._input(pslg, points), "pAenQ"))

    def mesh(self, pslg: Pslg, max_edge: float, fixed: bool) -> Mesh:
        # the area bound both fixed and per region: snapping can pinch a face into parts that
        # Triangle's flood fill from the one seed does not reach (labelled afterwards by position)
        max_area = AREA_FACTOR * max_edge ** 2
        return self._mesh(self._lib().triangulate(self._input(pslg, max_area=max_area),
                                                  f"pq{MIN_ANGLE}a{max_area!r}aAenQ{'YY' if fixed else ''}"))

    def refine(self, mesh: Mesh, pslg: Pslg, limits: np.ndarray, fixed: bool, whole: bool) -> Mesh:
        triangle = self._lib()
        attributes = (mesh.region + 1).astype(np.float64)[:, None]
        if whole:
            # new vertices must go where the surface bends, wherever that leads: refine everything,
            # splitting constraint pieces too (they carry the segment marker in the output)
            pieces = edge_pairs(mesh.constrained)
            return self._mesh(triangle.triangulate(
                {"vertices": mesh.vertices, "segments": pieces, "triangles": mesh.triangles,
                 "segment_markers": np.ones(len(pieces), dtype=np.int32), "triangle_attributes": attributes,
                 "triangle_max_area": limits}, f"prq{MIN_ANGLE}aenQ{'YY' if fixed else ''}"))
        patch = self._patch(limits > 0, mesh.triangles, mesh.neighbours)
        new_xy, new_tris, new_regions = self._refine_patch(triangle, mesh.vertices, mesh.triangles[patch],
                                                           attributes[patch], limits[patch], mesh.constrained)
        kept = np.ones(len(mesh.triangles), dtype=bool)
        kept[patch] = False
        origin = np.concatenate([np.flatnonzero(kept), np.full(len(new_tris), -1)])
        return Mesh(np.vstack([mesh.vertices, new_xy]), np.vstack([mesh.triangles[kept], new_tris]),
                    np.concatenate([mesh.region[kept], new_regions]), mesh.constrained, None, origin)

    @staticmethod
    def _patch(bad: np.ndarray, tris: np.ndarray, neighbours: np.ndarray | None) -> np.ndarray:
        """Indices of the bad triangles and their edge neighbours: the part of the mesh to refine.

        With the neighbours inside, every edge of a bad triangle that is not a constraint lies inside
        the patch, where refinement may split it. ``neighbours``: Triangle's, when still valid.
        """
        if neighbours is not None:
            near = neighbours[bad].ravel()
            return np.union1d(np.flatnonzero(bad), near[near >= 0])
        keys = triangle_edge_keys(tris)
        return np.flatnonzero(bad | np.isin(keys, keys[bad]).any(axis=1))

    @staticmethod
    def _refine_patch(triangle, xy: np.ndarray, tris: np.ndarray, attributes: np.ndarray, limits: np.ndarray,
                      constrained: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Refine a patch of the mesh on its own: (new vertices, its new triangles, their regions).

        The patch's outline and the constrained edges in it are segments that may not be split
        ("YY"), so the refined patch fits the untouched mesh around it exactly, and the constraint
        pieces stay as they are. Re-running Triangle over the whole mesh for the ~1 % of triangles
        that need it took longer than the first triangulation.
        """
        used, local = np.unique(tris, return_inverse=True)
        keys, count = np.unique(triangle_edge_keys(tris), return_counts=True)
        outline_or_constrained = keys[(count == 1) | np.isin(keys, constrained)]
        segments = np.searchsorted(used, edge_pairs(outline_or_constrained))
        out = triangle.triangulate({"vertices": xy[used], "segments": segments, "triangles": local.reshape(-1, 3),
                                    "triangle_attributes": attributes, "triangle_max_area": limits},
                                   f"prq{MIN_ANGLE}aYYQ")
        if not np.array_equal(out["vertices"][:len(used)], xy[used]):
            raise RuntimeError("Triangle renumbered the vertices of a refined patch.")
        new_xy = out["vertices"][len(used):]
        to_global = np.concatenate([used, np.arange(len(xy), len(xy) + len(new_xy))])
        return new_xy, to_global[out["triangles"]], np.rint(out["triangle_attributes"][:, 0]).astype(np.int64) - 1


class CdtBackend(Triangulator):
    key, label, module = 1, "CDT (MPL-2.0)", "pythoncdt"
    licence = "MPL-2.0 (pythoncdt, bindings of A. Amirkhanov's CDT): free for commercial use"
    piece_length = steiner.LATTICE_SPACING  # as long as the lattice's edges: short edges across the clear band

    def _lib(self):
        require([self.module])
        import pythoncdt

        return pythoncdt

    def triangulate(self, pslg: Pslg, points: np.ndarray | None = None,
                    regions: np.ndarray | None = None) -> Mesh:
        cdt = self._lib()
        live = cdt.Triangulation(cdt.VertexInsertionOrder.AUTO, cdt.IntersectingConstraintEdges.TRY_RESOLVE, 0.0)
        points, regions = _steiner(points, regions)
        live.insert_vertices(np.ascontiguousarray(np.vstack([pslg.vertices, points]), dtype=np.float64))
        live.insert_edges(np.ascontiguousarray(pslg.segments, dtype=np.uintc))
        vertex_region = np.concatenate([np.full(3 + len(pslg.vertices), -3, dtype=np.int64), regions])
        return self._read(live, vertex_region, pslg)

    def insert(self, mesh: Mesh, pslg: Pslg, points: np.ndarray, regions: np.ndarray) -> Mesh:
        live, vertex_region, before = mesh.state
        live.insert_vertices(np.ascontiguousarray(points, dtype=np.float64))
        return self._read(live, np.concatenate([vertex_region, regions]), pslg, before)

    def _read(self, live, vertex_region: np.ndarray, pslg: Pslg, before: tuple | None = None) -> Mesh:
        """The live triangulation as a ``Mesh``: the super-triangle (vertices 0–2) and what lies outside the
        area or in a hole left out, each triangle labelled with the region of its face.

        ``before``: (the library's triangles, their mesh rows) at the previous read. An insertion leaves most
        triangles where they were in the library's array: those with the same corners at the same place
        are the previous mesh's (``Mesh.origin``), found without sorting anything."""
        raw = live.vertices_array()
        xy = np.column_stack([raw["x"], raw["y"]])
        if len(vertex_region) < len(xy):  # vertices where segments met (none from clean constraints)
            vertex_region = np.concatenate([vertex_region, np.full(len(xy) - len(vertex_region), -3)])
        arrays = live.triangles_array()
        tris = arrays["vertices"].astype(np.int64)
        neighbours = arrays["neighbors"].astype(np.int64)
        neighbours[neighbours >= len(tris)] = -1
        if live.fixed_edges_count() == len(pslg.segments) and not live.piece_to_originals_count():
            constrained = np.unique(edge_keys(pslg.segments + 3))
        else:  # a segment split where it met another one or a vertex: its pieces
            constrained = np.unique(edge_keys(np.array([(e.v1, e.v2) for e in live.fixed_edges], dtype=np.int64)))
        outer = np.zeros(len(tris), dtype=bool)
        outer[np.fromiter(live.collect_outer_triangles(), dtype=np.int64)] = True
        outer |= (tris < 3).any(axis=1)
        region = face_regions(xy, tris, neighbours, constrained, vertex_region, outer, pslg.locate)
        meshed = np.flatnonzero(region != -1)
        final = region[meshed]
        final[final == -2] = -1
        origin = None
        if before is not None:
            old, old_row = before
            n = min(len(old), len(tris))
            same = np.zeros(len(tris), dtype=bool)
            same[:n] = (tris[:n] == old[:n]).all(axis=1)
            origin = np.where(same[meshed], np.pad(old_row, (0, max(len(tris) - len(old), 0)),
                                                   constant_values=-1)[meshed], -1)
        row = np.full(len(tris), -1)
        row[meshed] = np.arange(len(meshed))
        return Mesh(xy[3:], tris[meshed] - 3, final, constrained - (3 << 31) - 3, origin=origin,
                    state=(live, vertex_region, (tris, row)))


def _steiner(points: np.ndarray | None, regions: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Steiner points and their regions as arrays (none; −3: region not known)."""
    if points is None:
        return np.empty((0, 2)), np.empty(0, dtype=np.int64)
    return points, np.full(len(points), -3, dtype=np.int64) if regions is None else regions


def face_regions(xy: np.ndarray, tris: np.ndarray, neighbours: np.ndarray, constrained: np.ndarray,
                 vertex_region: np.ndarray, outer: np.ndarray, locate: Callable[..., np.ndarray]) -> np.ndarray:
    """Per triangle: the region of the face of the constraint graph it lies in, −1 outside (``outer``) or
    in a hole, −2 in a face that ``locate`` does not know.

    A Steiner point lies inside one face (its ``vertex_region``, ≥ 0), so does every triangle at it. The
    other triangles (constraint vertices only) are grouped into the parts of their faces across the
    edges that are not constraints; a part takes the region of a neighbour with a Steiner point, else
    ``locate`` of the centroid of its largest triangle.
    """
    region = np.where(outer, -1, vertex_region[tris].max(axis=1))
    unknown = np.flatnonzero(region < -1)
    if not len(unknown):
        return region
    k = np.repeat(np.arange(3)[None, :], len(unknown), axis=0)
    ends = np.stack([tris[unknown[:, None], k], tris[unknown[:, None], (k + 1) % 3]], axis=2)
    across = neighbours[unknown]
    open_ = (across >= 0) & ~np.isin(edge_keys(ends), constrained)
    a = np.repeat(np.arange(len(unknown)), 3)[open_.ravel()]
    b = across.ravel()[open_.ravel()]
    local = np.full(len(tris), -1)
    local[unknown] = np.arange(len(unknown))
    inner = local[b] >= 0
    label = components(len(unknown), a[inner], local[b[inner]])
    part_region = np.full(len(unknown), -3, dtype=np.int64)
    np.maximum.at(part_region, label[a[~inner]], region[b[~inner]])
    corners = xy[tris[unknown]]
    area = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    by_size = np.lexsort((-area, label))
    first = by_size[np.r_[True, label[by_size][1:] != label[by_size][:-1]]]  # the largest of each part
    first = first[part_region[label[first]] < -1]
    part_region[label[first]] = locate(corners[first].mean(axis=1))
    region[unknown] = part_region[label]
    return region


def components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The connected component (its smallest member) of each of ``n`` nodes joined by the pairs ``a``–``b``:
    hooking and pointer jumping, a few vectorised passes."""
    label = np.arange(n)
    while True:
        la, lb = label[a], label[b]
        differ = la != lb
        if not differ.any():
            return label
        np.minimum.at(label, np.maximum(la, lb)[differ], np.minimum(la, lb)[differ])
        while True:
            jumped = label[label]
            if np.array_equal(jumped, label):
                break
            label = jumped


BACKENDS: tuple[Triangulator, ...] = (TriangleBackend(), CdtBackend())
TRIANGLE, CDT = (backend.key for backend in BACKENDS)
#: the TRIANGULATOR options, in order
LABELS = tuple(backend.label for backend in BACKENDS)


def available(backend: Triangulator) -> bool:
    """The backend's library can be imported."""
    try:
        importlib.import_module(backend.module)
    except ImportError:
        return False
    return True


def default_key() -> int:
    """Triangle where the user has it (the proven default), else CDT."""
    return BACKENDS[0].key if available(BACKENDS[0]) else BACKENDS[1].key


def backend(key: int | None) -> Triangulator:
    """The backend of a TRIANGULATOR option (None: ``default_key``)."""
    key = default_key() if key is None else key
    if key not in range(len(BACKENDS)):
        raise ValueError(f"No triangulator {key!r}: choose one of " + ", ".join(
            f"{b.key} ({b.label})" for b in BACKENDS) + ".")
    return BACKENDS[key]


def announce(backend: Triangulator, feedback: Feedback) -> None:
    """Say which backend meshes the terrain and under which licence (a terrain step's log, a tiled run's)."""
    feedback.info(f"Triangulator: {backend.label}; licence: {backend.licence}.")
