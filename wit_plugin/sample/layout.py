"""Synthetic Gangnam-like city layout: street grid, blocks, parcels and building footprints.

The layout imitates south-east Seoul: a slightly rotated grid of arterial roads (30–50 m)
around superblocks of 300–650 m; inside them villa quarters cut by 6–12 m lanes, commercial
blocks along collectors, apartment complexes (단지) with slab or tower blocks facing south,
schools, parks, and forest on the hills (대모산, 구룡산). Blocks are the road cells inset by
half the road width plus a sidewalk, so roads never run through buildings.

Every superblock is generated from its own random stream keyed by (seed, i, j), so the content
of a place does not depend on how large an area is requested: the study area and the wider
orthoimage footprint see the same city. The real names and codes it uses are in ``gangnam``;
what fills a block (houses, shops, apartment slabs, schools, parks) is in ``blocks``.
"""
from __future__ import annotations

import math
import random

import numpy as np
from pyproj import Transformer

from .blocks import _FILLERS, InnerRoad, Superblock, _Quad
from .gangnam import ARTERIALS, DONGS, SUSEO_DONG, SUSEO_STATION_5179


def line_rank(index: int) -> int:
    """0, 1, -1, 2, -2, … → 0, 1, 2, 3, 4: lines near the centre get the first names."""
    return 2 * index - 1 if index > 0 else -2 * index


class CityLayout:
    """The arterial grid around a centre point and its superblocks, generated on demand."""

    def __init__(self, center_xy: tuple[float, float], seed: int, terrain):
        """``terrain(x, y)`` gives heights at EPSG:5186 points (hills become forest)."""
        self.center = np.asarray(center_xy, dtype=float)
        self.seed = seed
        self._terrain = terrain
        self._to_5186 = Transformer.from_crs("EPSG:5179", "EPSG:5186", always_xy=True)
        rng = np.random.default_rng([seed, 1])
        self.theta = math.radians(rng.uniform(-28.0, 28.0))
        self._axes = np.array([[math.cos(self.theta), math.sin(self.theta)],
                               [-math.sin(self.theta), math.cos(self.theta)]])  # rows: u and v directions
        self._lines = {"u": _LinePositions(seed, 0, rng.uniform(-200, 200), (380.0, 620.0)),
                       "v": _LinePositions(seed, 1, rng.uniform(-200, 200), (320.0, 540.0))}
        self._cache: dict[tuple[int, int], Superblock] = {}
        self._nodes: dict[tuple[int, int], np.ndarray] = {}

    # --- grid geometry -------------------------------------------------------------------------
    def axis(self, family: str) -> np.ndarray:
        """Unit direction along which a ``family`` line runs ('u' lines run along v and vice versa)."""
        return self._axes[1] if family == "u" else self._axes[0]

    def arterial(self, family: str, index: int) -> tuple:
        """The real road (ARTERIALS row) naming grid line ``index`` of ``family``."""
        return ARTERIALS[(2 * line_rank(index) + (family == "v")) % len(ARTERIALS)]

    def node(self, i: int, j: int) -> np.ndarray:
        if (i, j) not in self._nodes:
            jitter = np.random.default_rng([self.seed, 3, i + 100000, j + 100000]).uniform(-22.0, 22.0, 2)
            uv = np.array([self._lines["u"].at(i), self._lines["v"].at(j)])
            self._nodes[(i, j)] = self.center + uv @ self._axes + jitter
        return self._nodes[(i, j)]

    def line_coords(self, family: str, index: int, lo: int, hi: int) -> np.ndarray:
        """Centre line of arterial ``index`` through the nodes lo..hi of the other family."""
        if family == "u":
            return np.array([self.node(index, k) for k in range(lo, hi + 1)])
        return np.array([self.node(k, index) for k in range(lo, hi + 1)])

    def arterial_runs(self, family: str, index: int, lo: int, hi: int) -> list[np.ndarray]:
        """Pieces of ``line_coords`` that are real roads: stretches with forest on both sides are left out."""
        nodes = self.line_coords(family, index, lo, hi)
        runs, start = [], 0
        for k in range(lo, hi + 1):
            sides = [(index - 1, k), (index, k)] if family == "u" else [(k, index - 1), (k, index)]
            if k == hi or all(self.superblock(*s).kind == "forest" for s in sides):
                if k - lo > start:
                    runs.append(nodes[start:k - lo + 1])
                start = k - lo + 1
        return runs

    def index_range(self, bbox: tuple[float, float, float, float]) -> tuple[range, range]:
        """Superblock indices (i, j) whose cells may meet ``bbox`` (EPSG:5179)."""
        xs, ys = np.array([bbox[0], bbox[2], bbox[2], bbox[0]]), np.array([bbox[1], bbox[1], bbox[3], bbox[3]])
        uv = (np.column_stack([xs, ys]) - self.center) @ self._axes.T
        ranges = []
        for k, family in enumerate("uv"):
            lines = self._lines[family]
            lo, hi = lines.index_below(uv[:, k].min() - 30.0), lines.index_below(uv[:, k].max() + 30.0)
            ranges.append(range(lo, hi + 1))
        return ranges[0], ranges[1]

    def superblocks(self, bbox: tuple[float, float, float, float]) -> list[Superblock]:
        """All superblocks meeting ``bbox``, in (i, j) order."""
        irange, jrange = self.index_range(bbox)
        return [self.superblock(i, j) for i in irange for j in jrange]

    def superblock(self, i: int, j: int) -> Superblock:
        if (i, j) not in self._cache:
            self._cache[(i, j)] = self._make_superblock(i, j)
        return self._cache[(i, j)]

    # --- superblock content --------------------------------------------------------------------
    def _make_superblock(self, i: int, j: int) -> Superblock:
        rng = random.Random(f"{self.seed}:{i}:{j}")  # nosec B311  # sample layout, no secret; ~50x numpy's speed
        corners = np.array([self.node(i, j), self.node(i + 1, j), self.node(i + 1, j + 1), self.node(i, j + 1)])
        centroid = corners.mean(axis=0)
        dong = self._dong_at(centroid, corners)
        kind = rng.choices(["villa", "apartment", "commercial", "park"], [0.5, 0.3, 0.17, 0.03])[0]
        if _contains(corners, self.center):
            kind = "commercial"  # the station quarter
        heights = self._heights(np.vstack([corners, centroid[None]]))
        if heights.mean() > 55.0:
            kind = "forest"
        sb = Superblock((i, j), corners, str(kind), dong)
        widths = np.array([self.arterial("v", j)[3], self.arterial("u", i + 1)[3],
                           self.arterial("v", j + 1)[3], self.arterial("u", i)[3]])
        a_lines, b_lines = _inner_lines(sb.kind, corners, rng)
        grid = _CellGrid(corners, a_lines, b_lines, widths)
        for k, (coords, width) in enumerate(grid.inner_roads()):
            family, index = ("v", j) if k < len(a_lines) else ("u", i)
            sb.roads.append(InnerRoad(coords, width, (family, index)))
        cells = grid.cells(rng)
        cell_heights: np.ndarray | list[float] = (
            self._heights(np.array([c.mean(axis=0) for c, _, _ in cells])) if cells else [])
        kinds = _cell_kinds(sb.kind, len(cells), rng)
        for block, ((_, inset, frontage), h, cell_kind) in enumerate(zip(cells, cell_heights, kinds)):
            if inset is None:
                continue
            if h > 45.0:
                cell_kind = "forest"
            _FILLERS[cell_kind](_Quad(inset), frontage, block, dong, rng, sb)
        return sb

    def _heights(self, points: np.ndarray) -> np.ndarray:
        x, y = self._to_5186.transform(points[:, 0], points[:, 1])
        return self._terrain(np.asarray(x), np.asarray(y))

    def _dong_at(self, centroid: np.ndarray, corners: np.ndarray) -> int:
        """Nearest real dong centre; the station's superblock is always Suseo-dong."""
        if _contains(corners, np.array(SUSEO_STATION_5179)):
            return SUSEO_DONG
        seeds = np.array([[d[3], d[4]] for d in DONGS]) + np.array(SUSEO_STATION_5179)
        return int(np.argmin(((seeds - centroid) ** 2).sum(axis=1)))


class _LinePositions:
    """Positions of grid lines along one axis, extended lazily outwards from line 0."""

    def __init__(self, seed: int, axis: int, start: float, spacing: tuple[float, float]):
        self._spacing = spacing
        self._rngs = {1: np.random.default_rng([seed, 4, axis, 1]), -1: np.random.default_rng([seed, 4, axis, 0])}
        self._pos = {1: [start], -1: [start]}

    def at(self, index: int) -> float:
        side = 1 if index >= 0 else -1
        pos = self._pos[side]
        while len(pos) <= abs(index):
            pos.append(pos[-1] + side * self._rngs[side].uniform(*self._spacing))
        return pos[abs(index)]

    def index_below(self, value: float) -> int:
        """The largest index whose line lies at or below ``value`` (with jitter margin)."""
        k = 0
        while self.at(k) > value:
            k -= 1
        while self.at(k + 1) <= value:
            k += 1
        return k


def _contains(quad: np.ndarray, point: np.ndarray) -> bool:
    """Point in a convex CCW quad."""
    edges = np.roll(quad, -1, axis=0) - quad
    rel = point - quad
    return bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] >= 0))


def _inner_lines(kind: str, corners: np.ndarray, rng: random.Random):
    """Inner road lines as (fraction at start edge, fraction at end edge, width) for both families.

    Family A runs from the bottom edge to the top edge (a fraction along u), family B from the left
    to the right edge. Ends differ slightly so that inner roads are not parallel to the arterials.
    """
    length_u = float(0.5 * (np.linalg.norm(corners[1] - corners[0]) + np.linalg.norm(corners[2] - corners[3])))
    length_v = float(0.5 * (np.linalg.norm(corners[3] - corners[0]) + np.linalg.norm(corners[2] - corners[1])))
    if kind == "villa":
        a = _splits(length_u, (95.0, 140.0), lambda k, n: 15.0 + 5 * rng.random() if k == n // 2 else
                    rng.choice([8.0, 10.0, 12.0]), rng)
        b = _splits(length_v, (40.0, 47.0), lambda k, n: rng.choice([6.0, 6.0, 8.0]), rng)
    elif kind == "commercial":
        a = _splits(length_u, (110.0, 150.0), lambda k, n: rng.choice([12.0, 15.0, 20.0, 25.0]), rng)
        b = _splits(length_v, (62.0, 90.0), lambda k, n: rng.choice([8.0, 10.0, 12.0]), rng)
    elif kind == "apartment":
        a = _splits(length_u, (260.0, 400.0), lambda k, n: float(rng.uniform(15.0, 25.0)), rng)
        b = _splits(length_v, (260.0, 400.0), lambda k, n: float(rng.uniform(15.0, 25.0)), rng)
    else:
        a, b = [], []
    return a, b


def _splits(length: float, spacing: tuple[float, float], width, rng: random.Random):
    n = max(1, int(round(length / rng.uniform(*spacing))))
    cuts = np.cumsum([rng.uniform(0.85, 1.15) for _ in range(n)])
    cuts = cuts[:-1] / cuts[-1]
    lines = []
    for k, c in enumerate(cuts):
        skew = rng.uniform(-0.015, 0.015)
        lines.append((c, float(np.clip(c + skew, 0.02, 0.98)), width(k, len(cuts))))
    return lines


def _intersect(p1: np.ndarray, d1: np.ndarray, p2: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """Intersection of the lines p1 + s d1 and p2 + t d2."""
    den = d1[0] * d2[1] - d1[1] * d2[0]
    s = ((p2[0] - p1[0]) * d2[1] - (p2[1] - p1[1]) * d2[0]) / den
    return p1 + s * d1


def _inset(quad: np.ndarray, distances: np.ndarray) -> np.ndarray | None:
    """The convex CCW quad with every edge moved inwards by its distance; None if it vanishes."""
    starts, dirs = quad, np.roll(quad, -1, axis=0) - quad
    lengths = np.linalg.norm(dirs, axis=1)
    normals = np.column_stack([-dirs[:, 1], dirs[:, 0]]) / lengths[:, None]
    moved = starts + normals * distances[:, None]
    out = np.array([_intersect(moved[k - 1], dirs[k - 1], moved[k], dirs[k]) for k in range(4)])
    edges = np.roll(out, -1, axis=0) - out
    cross = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
    if np.any(cross <= 0) or np.any(np.linalg.norm(edges, axis=1) < 12.0):
        return None
    return out


class _CellGrid:
    """A superblock cut by its inner roads into cells; cell corners are shared exactly."""

    def __init__(self, corners: np.ndarray, a_lines, b_lines, arterial_widths: np.ndarray):
        c00, c10, c11, c01 = corners
        self.a = [(c00, c01 - c00)] + [(c00 + s0 * (c10 - c00), (c01 + s1 * (c11 - c01)) - (c00 + s0 * (c10 - c00)))
                                       for s0, s1, _ in a_lines] + [(c10, c11 - c10)]
        self.b = [(c00, c10 - c00)] + [(c00 + t0 * (c01 - c00), (c10 + t1 * (c11 - c10)) - (c00 + t0 * (c01 - c00)))
                                       for t0, t1, _ in b_lines] + [(c01, c11 - c01)]
        bottom, right, top, left = arterial_widths
        self.wa = [left] + [w for *_, w in a_lines] + [right]
        self.wb = [bottom] + [w for *_, w in b_lines] + [top]
        self.points = np.array([[_intersect(*self.a[k], *self.b[m]) for m in range(len(self.b))]
                                for k in range(len(self.a))])

    def inner_roads(self) -> list[tuple[np.ndarray, float]]:
        """Family A roads, then family B, with a vertex at every crossing."""
        ka, kb = len(self.a) - 1, len(self.b) - 1
        roads = [(self.points[k, :, :], self.wa[k]) for k in range(1, ka)]
        roads += [(self.points[:, m, :], self.wb[m]) for m in range(1, kb)]
        return roads

    def cells(self, rng: random.Random):
        """(cell corners, inset buildable quad or None, sides facing an arterial) per cell."""
        ka, kb = len(self.a) - 1, len(self.b) - 1
        out = []
        for k in range(ka):
            for m in range(kb):
                p = self.points
                cell = np.array([p[k, m], p[k + 1, m], p[k + 1, m + 1], p[k, m + 1]])
                arterial = (m == 0, k + 1 == ka, m + 1 == kb, k == 0)
                widths = np.array([self.wb[m], self.wa[k + 1], self.wb[m + 1], self.wa[k]])
                sidewalks = np.array([rng.uniform(2.5, 4.5) if a else rng.uniform(1.0, 2.2) for a in arterial])
                out.append((cell, _inset(cell, widths / 2 + sidewalks), arterial))
        return out


def _cell_kinds(kind: str, n: int, rng: random.Random) -> list[str]:
    if kind in ("park", "forest"):
        return [kind] * n
    if kind == "villa":
        return ["park" if rng.random() < 0.06 else "villa" for _ in range(n)]
    if kind == "commercial":
        return ["culture" if rng.random() < 0.05 else "commercial" for _ in range(n)]
    kinds = ["apartment"] * n
    if n > 1 and rng.random() < 0.4:
        kinds[rng.randrange(n)] = "school" if rng.random() < 0.6 else "park"
    return kinds
