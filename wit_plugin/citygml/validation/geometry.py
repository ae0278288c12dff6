"""Geometric checks, vectorised over many solids or triangles at once, in local metres.

Positions arrive in their CRS's units with a ``Frame`` per solid (or per triangle batch); each
solid is moved into east/north/up metres around its first vertex, so every tolerance is in metres
whether the CRS is projected or geographic (see ``crs``).
"""
from __future__ import annotations

import operator
import re
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from itertools import repeat
from typing import NamedTuple

import numpy as np
import shapely

from .crs import Frame
from .names import IssueList

_POINT_IN_REASON = re.compile(r"\[\s*([-+0-9.eE]+)\s+([-+0-9.eE]+)")


class Where(NamedTuple):
    """Where a solid or face is, kept instead of the element so that checked parts can be freed."""
    line: int | None
    gml_id: str | None
    label: str


@dataclass
class SolidBatch:
    """Solids as flat arrays: every ring's positions (closing one included), ring → face → solid."""
    solids: list[Where]
    frames: list[Frame]
    points: np.ndarray  # (P, 3) in CRS units
    ring_len: np.ndarray  # (R,) positions per ring
    ring_face: np.ndarray  # (R,) face of each ring
    face_solid: np.ndarray  # (F,) solid of each face
    face_where: Callable[[int], Where]  # looked up only for messages


def local_frames(frames: list[Frame], origins: np.ndarray) -> tuple[list[Frame], np.ndarray, list[Frame]]:
    """Per origin: its frame (axis order fixed when the latitude is impossible), metres per unit, swapped frames."""
    if frames and all(map(operator.is_, frames, repeat(frames[0]))):  # one frame: vectorised
        frame = frames[0]
        if not frame.geographic:
            return frames, frame.metres_per_unit(origins), []
        lat = np.abs(origins[:, frame.lat_axis])
        flip = (lat > 90) & (np.abs(origins[:, 1 - frame.lat_axis]) <= 90)
        if not flip.any():
            return frames, frame.metres_per_unit(origins), []
    fixed, swapped = [], []
    for frame, origin in zip(frames, origins):
        if frame.geographic and abs(origin[frame.lat_axis]) > 90 >= abs(origin[1 - frame.lat_axis]):
            frame = frame.swapped()
            swapped.append(frame)
        fixed.append(frame)
    per_unit = np.ones_like(origins, dtype=float)
    for frame in set(fixed):
        rows = np.fromiter((f == frame for f in fixed), dtype=bool, count=len(fixed))
        per_unit[rows] = frame.metres_per_unit(origins[rows])
    return fixed, per_unit, swapped


def to_local(points: np.ndarray, owner: np.ndarray, frames: list[Frame], origins: np.ndarray,
             per_unit: np.ndarray) -> np.ndarray:
    """East/north/up metres of ``points`` from the origin of their owner (a solid or triangle)."""
    local = (points - origins[owner]) * per_unit[owner]
    lat_first = np.fromiter((f.lat_axis == 0 for f in frames), dtype=bool, count=len(frames))
    if lat_first.any():
        rows = lat_first[owner]
        local[rows] = local[rows][:, [1, 0, 2]]
    return local


def triangle_areas(corners: np.ndarray, frames: list[Frame]) -> tuple[np.ndarray, list[Frame]]:
    """Area in m² of triangles given as (T, 3, 3) corners, each with its frame; and the frames read swapped."""
    origins = corners[:, 0]
    fixed, per_unit, swapped = local_frames(frames, origins)
    owner = np.repeat(np.arange(len(corners)), 3)
    local = to_local(corners.reshape(-1, 3), owner, fixed, origins, per_unit).reshape(-1, 3, 3)
    return 0.5 * np.linalg.norm(np.cross(local[:, 1] - local[:, 0], local[:, 2] - local[:, 0]), axis=1), swapped


class SolidCheck:
    """Closedness, orientation, planarity and simplicity of a batch of solids."""

    def __init__(self, batch: SolidBatch, issues: IssueList, vertex_tol: float, planarity_tol: float):
        self.batch, self.issues, self.tol, self.planarity_tol = batch, issues, vertex_tol, planarity_tol
        self.swapped: list[Frame] = []

    def run(self) -> None:
        b, tol = self.batch, self.tol
        ring_start = np.r_[0, np.cumsum(b.ring_len)[:-1]]
        ring_solid = b.face_solid[b.ring_face]
        point_ring = np.repeat(np.arange(len(b.ring_len)), b.ring_len)
        _, first_ring = np.unique(ring_solid, return_index=True)
        origins = b.points[ring_start[first_ring]]
        self.frames, self.per_unit, self.swapped = local_frames(b.frames, origins)
        self.origins = origins
        local = to_local(b.points, ring_solid[point_ring], self.frames, origins, self.per_unit)
        ring_end = ring_start + b.ring_len - 1
        short = b.ring_len < 4
        gap = np.abs(local[ring_start] - local[np.maximum(ring_end, ring_start)]).max(axis=1) > tol
        bad_ring = short | gap
        for r in np.flatnonzero(bad_ring):
            node = b.face_where(int(b.ring_face[r]))
            if short[r]:
                self.issues.add("polygon", node.line, node.gml_id, f"A ring of face {node.label} has {b.ring_len[r]} "
                                "positions; a ring needs at least 4 (3 corners and the first repeated).")
            else:
                self.issues.add("polygon", node.line, node.gml_id, f"A ring of face {node.label} is not closed: its "
                                "last position must repeat the first.")
        face_ok = np.ones(len(b.face_solid), dtype=bool)
        face_ok[b.ring_face[bad_ring]] = False
        self.broken = set(b.face_solid[~face_ok].tolist())  # a face dropped: topology would mislead
        self.good_faces = np.flatnonzero(face_ok)
        if not len(self.good_faces):
            return
        renumber = np.full(len(face_ok), -1)
        renumber[self.good_faces] = np.arange(len(self.good_faces))
        ring_kept = face_ok[b.ring_face]
        keep = ring_kept[point_ring] & (np.arange(len(local)) != ring_end[point_ring])  # closing positions go
        self.v = local[keep]
        kept_rings = np.flatnonzero(ring_kept)
        self.vert_ring = np.repeat(np.arange(len(kept_rings)), b.ring_len[kept_rings] - 1)
        self.ring_face = renumber[b.ring_face[kept_rings]]
        self.face_solid = b.face_solid[self.good_faces]
        ring_len = b.ring_len[kept_rings] - 1
        starts = np.r_[0, np.cumsum(ring_len)[:-1]]
        self.nxt = np.arange(len(self.v)) + 1
        self.nxt[starts + ring_len - 1] = starts
        self.vert_face = self.ring_face[self.vert_ring]
        self._faces()
        self._topology()

    def _face(self, f: int) -> Where:
        return self.batch.face_where(int(self.good_faces[f]))

    def _xyz(self, p: np.ndarray, s: int) -> str:
        """A local position as the file writes it (CRS units and axis order)."""
        frame = self.frames[s]
        crs = frame.from_local(p, self.origins[s], self.per_unit[s])
        return "(" + " ".join(f"{c:.{frame.decimals}f}" for c in crs) + ")"

    def _faces(self) -> None:
        """Area, planarity and self-intersection of every face; signed volume of every solid."""
        issues, v, w, vf = self.issues, self.v, self.v[self.nxt], self.vert_face
        nfaces = len(self.good_faces)
        terms = np.column_stack([(v[:, 1] - w[:, 1]) * (v[:, 2] + w[:, 2]), (v[:, 2] - w[:, 2]) * (v[:, 0] + w[:, 0]),
                                 (v[:, 0] - w[:, 0]) * (v[:, 1] + w[:, 1])])
        normal = np.column_stack([np.bincount(vf, terms[:, k], nfaces) for k in range(3)])  # 2 × area vector
        count = np.bincount(vf, minlength=nfaces)
        centroid = np.column_stack([np.bincount(vf, v[:, k], nfaces) for k in range(3)]) / count[:, None]
        length = np.linalg.norm(normal, axis=1)
        flat = length / 2 <= max(self.tol ** 2, 1e-12)
        unit = normal / np.where(flat, 1.0, length)[:, None]
        dist = np.abs(((v - centroid[vf]) * unit[vf]).sum(axis=1))
        face_start = np.flatnonzero(np.r_[True, vf[1:] != vf[:-1]])
        worst = np.maximum.reduceat(dist, face_start)
        self.volume = np.bincount(self.face_solid, (centroid * normal).sum(axis=1), len(self.batch.solids)) / 6.0
        self.flat_solid = set(self.face_solid[flat].tolist())
        for f in np.flatnonzero(flat):
            node, pts = self._face(f), v[vf == f]
            spread = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
            if len(spread) > 1 and spread[1] > self.tol * np.sqrt(len(pts)):
                issues.add("self-intersection", node.line, node.gml_id, f"Face {node.label} intersects itself (its "
                           "signed area is zero although its points span a plane: a bow-tie or figure-eight ring).")
            else:
                issues.add("polygon", node.line, node.gml_id, f"Face {node.label} has zero area (its points "
                           "coincide or are collinear).")
        for f in np.flatnonzero(~flat & (worst > self.planarity_tol)):
            node = self._face(f)
            issues.add("planarity", node.line, node.gml_id, f"Face {node.label} is not planar: a vertex lies "
                       f"{worst[f]:.3f} m from the face's plane (tolerance {self.planarity_tol:g} m).")
        self._self_intersections(flat, normal, unit, centroid)

    def _self_intersections(self, flat: np.ndarray, normal: np.ndarray, unit: np.ndarray, centroid: np.ndarray) -> None:
        """Each face projected on the coordinate plane its normal is closest to, tested by GEOS.

        A face with one ring that turns one way, once around (convex: most walls and roofs), cannot
        cross itself; only the others go to GEOS.
        """
        v, vf = self.v, self.vert_face
        axis = np.argmax(np.abs(normal), axis=1)
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        plane = np.column_stack([v[np.arange(len(v)), a1[vf]], v[np.arange(len(v)), a2[vf]]])
        keep = ~flat[vf] & ~self._convex(plane)[vf]
        idx = np.flatnonzero(keep)
        if not len(idx):
            return
        xy = plane[idx]
        ring_ids = self.vert_ring[idx]
        _, ring_seq = np.unique(ring_ids, return_inverse=True)
        linear = shapely.linearrings(xy, indices=ring_seq)
        ring_of = np.unique(ring_ids)
        faces_of_rings = self.ring_face[ring_of]
        _, face_seq = np.unique(faces_of_rings, return_inverse=True)
        polys = shapely.polygons(linear, indices=face_seq)
        face_list = np.unique(faces_of_rings)
        for k in np.flatnonzero(~shapely.is_valid(polys)):
            f = face_list[k]
            node = self._face(f)
            reason = shapely.is_valid_reason(polys[k])
            where = ""
            m = _POINT_IN_REASON.search(reason)
            if m:
                p = np.zeros(3)
                p[a1[f]], p[a2[f]] = float(m.group(1)), float(m.group(2))
                n, c = unit[f], centroid[f]
                p[axis[f]] = c[axis[f]] - (n[a1[f]] * (p[a1[f]] - c[a1[f]])
                                           + n[a2[f]] * (p[a2[f]] - c[a2[f]])) / n[axis[f]]
                where = " near " + self._xyz(p, self.face_solid[f])
            self.issues.add("self-intersection", node.line, node.gml_id, f"Face {node.label} intersects itself"
                            f"{where} ({reason.split('[')[0].strip()}).")

    def _convex(self, xy: np.ndarray) -> np.ndarray:
        """Per face: one ring whose turns all go one way and add up to one full turn."""
        nfaces = len(self.good_faces)
        prev = np.empty_like(self.nxt)
        prev[self.nxt] = np.arange(len(self.nxt))
        e1, e2 = xy - xy[prev], xy[self.nxt] - xy
        cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        turn = np.arctan2(cross, (e1 * e2).sum(axis=1))
        vf = self.vert_face
        left = np.bincount(vf, cross > 0, nfaces) > 0
        right = np.bincount(vf, cross < 0, nfaces) > 0
        total = np.abs(np.bincount(vf, turn, nfaces))
        one_ring = np.bincount(self.ring_face, minlength=nfaces) == 1
        return one_ring & (left != right) & (np.abs(total - 2 * np.pi) < 1e-6)

    def _topology(self) -> None:
        """Every edge in exactly two faces, once in each direction; then outward by signed volume."""
        v = self.v
        vs = self.face_solid[self.vert_face]
        vid = _vertex_ids(vs, np.round(v / self.tol).astype(np.int64))
        suspicious = self._suspicious(vid)
        for s, solid in enumerate(self.batch.solids):
            if s in self.broken:
                continue
            if s in suspicious:
                mask = vs == s
                self._explain(s, solid, np.flatnonzero(mask), _tolerant_ids(v[mask], self.tol))
            elif s not in self.flat_solid:
                self._outward(s, solid)

    def _suspicious(self, vid: np.ndarray) -> set[int]:
        a, b = vid, vid[self.nxt]
        real = a != b
        solid_of_edge = self.face_solid[self.vert_face][real]
        a, b = a[real], b[real]
        m = int(vid.max()) + 1
        _, inv, cnt = np.unique(np.minimum(a, b) * m + np.maximum(a, b), return_inverse=True, return_counts=True)
        _, dinv, dcnt = np.unique(a * m + b, return_inverse=True, return_counts=True)
        bad = (cnt[inv.ravel()] != 2) | (dcnt[dinv.ravel()] != 1)
        return set(solid_of_edge[bad].tolist())

    def _explain(self, s: int, solid: Where, vidx: np.ndarray, local_ids: list[int]) -> None:
        """Report why a solid failed the fast edge test (after matching vertices at the tolerance)."""
        sid = solid.gml_id
        ids = dict(zip(vidx.tolist(), local_ids))
        undirected: dict = defaultdict(list)
        for i in vidx.tolist():
            a, b = ids[i], ids[self.nxt[i]]
            if a != b:
                undirected[min(a, b), max(a, b)].append((int(self.vert_face[i]), a < b, i))
        open_edges = [(k, uses) for k, uses in undirected.items() if len(uses) != 2]
        if open_edges:
            (_, uses), n = open_edges[0], len(open_edges)
            i = uses[0][2]
            faces = ", ".join(sorted({self._face(f).label for f, _, _ in uses}))
            ends = f"{self._xyz(self.v[i], s)} – {self._xyz(self.v[self.nxt[i]], s)}"
            what = "is used by only one face: the shell has a hole" if len(uses) == 1 else \
                f"is shared by {len(uses)} faces"
            self.issues.add("solid-closed", solid.line, sid, f"Solid {sid or ''} is not closed: edge {ends} (face "
                            f"{faces}) {what}" + (f"; {n - 1} more such edges." if n > 1 else "."))
            return
        if all(d1 != d2 for (_, d1, _), (_, d2, _) in undirected.values()):
            if s not in self.flat_solid:
                self._outward(s, solid)  # only the fast vertex matching was fooled
            return
        # closed: find the faces whose orientation disagrees with their neighbours
        neighbours: dict = defaultdict(list)
        for (f1, d1, _), (f2, d2, _) in undirected.values():
            neighbours[f1].append((f2, d1 == d2))
            neighbours[f2].append((f1, d1 == d2))
        parity: dict[int, int] = {}
        for start in neighbours:
            if start in parity:
                continue
            parity[start], todo = 0, [start]
            while todo:
                f = todo.pop()
                for g, flip in neighbours[f]:
                    want = parity[f] ^ flip
                    if g not in parity:
                        parity[g] = want
                        todo.append(g)
                    elif parity[g] != want:
                        self.issues.add("solid-orientation", solid.line, sid, f"Solid {sid or ''} cannot be oriented "
                                        "consistently (its shell is not a proper closed surface).")
                        return
        groups = [sorted(f for f, p in parity.items() if p == k) for k in (0, 1)]
        minority = min(groups, key=len)
        names = ", ".join(self._face(f).label for f in minority[:10])
        self.issues.add("solid-orientation", solid.line, sid, f"Solid {sid or ''}: face(s) {names} are oriented "
                        "opposite to their neighbours; reverse their vertex order so all faces point outwards.")

    def _outward(self, s: int, solid: Where) -> None:
        vol, sid = self.volume[s], solid.gml_id
        if vol < 0:
            frame = self.frames[s]
            hint = "" if not frame.disputed else (
                f" — unless the coordinates are written {frame.other_order}: {frame.name} is read {frame.order}, and "
                "read the other way the solid points outwards; then give the srsName that says so (EPSG:n for "
                "longitude/easting first, its URN or URL for EPSG's order)")
            self.issues.add("solid-orientation", solid.line, sid, f"Solid {sid or ''} is inside out: all faces point "
                            f"inwards (signed volume {vol:.3f} m³); reverse the vertex order of every face{hint}.")
        elif vol <= self.tol ** 3:
            self.issues.add("solid-closed", solid.line, sid, f"Solid {sid or ''} encloses no volume.")


def _vertex_ids(solid: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """One id per distinct (solid, grid cell): cells packed into one int64 when they fit, then sorted by both."""
    if len(cells) and np.abs(cells).max() < 1 << 20:
        packed = ((cells[:, 0] + (1 << 20)) << 42) | ((cells[:, 1] + (1 << 20)) << 21) | (cells[:, 2] + (1 << 20))
        order = np.lexsort((packed, solid))
        s, p = solid[order], packed[order]
        new = np.r_[True, (s[1:] != s[:-1]) | (p[1:] != p[:-1])]
        ids = np.empty(len(order), dtype=np.int64)
        ids[order] = np.cumsum(new) - 1
        return ids
    _, ids = np.unique(np.column_stack([solid, cells]), axis=0, return_inverse=True)
    return ids.ravel()


def _tolerant_ids(points: np.ndarray, tol: float) -> list[int]:
    """Vertex ids where points within ``tol`` share an id (grid cells plus their 26 neighbours)."""
    cells: dict = defaultdict(list)
    ids: list[int] = []
    reps: list[np.ndarray] = []
    offsets = [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)]
    for p in points:
        c = tuple(np.floor(p / tol).astype(int))
        found = next((j for o in offsets for j in cells.get((c[0] + o[0], c[1] + o[1], c[2] + o[2]), ())
                      if np.abs(reps[j] - p).max() <= tol), None)
        if found is None:
            found = len(reps)
            reps.append(p)
            cells[c].append(found)
        ids.append(found)
    return ids
