"""What fills a superblock of the synthetic city: buildings (villas, shops, offices, apartment slabs and
towers, schools), lanes, parks and forest, each block from its own random stream."""
from __future__ import annotations

import random
from dataclasses import dataclass, field

import numpy as np
import shapely

from .gangnam import (
    APARTMENT,
    APT_BRANDS,
    DETACHED_HOUSE,
    GROUND_BARE,
    GROUND_FOREST,
    GROUND_LANE,
    GROUND_LAWN,
    GROUND_PARKING,
    MULTI_HOUSEHOLD,
    MULTIPLEX,
    OFFICE,
    OFFICE_PREFIXES,
    OFFICE_SUFFIXES,
    PERFORMANCE_HALL,
    RESTAURANT,
    RETAIL,
    ROOF_BLUE_METAL,
    ROOF_BROWN_TILE,
    ROOF_CONCRETE,
    ROOF_DARK,
    ROOF_GREEN,
    ROOF_RED_TILE,
    ROOF_WHITE,
    ROW_HOUSE,
    SCHOOLS,
    VILLA_NAMES,
    dong_stem,
)


@dataclass
class Building:
    """One footprint before attribute assignment (rings closed; exterior CCW, holes CW)."""

    rings: list[np.ndarray]
    use: str
    floors: int
    under: int
    roof: int
    block: int  # sub-block number within the superblock: buildings of a block share a main lot number
    sub: int  # lot sub-number (부번), 0 for a whole apartment or school site
    name: str = ""
    name_dc: str = ""
    eng: str = ""
    detached: bool = True  # no wall shared with a neighbour


@dataclass
class InnerRoad:
    """A collector or local road inside a superblock, branching off the arterial ``parent``."""

    coords: np.ndarray
    width: float
    parent: tuple[str, int]  # ('u' | 'v', line index) of the arterial it branches from


@dataclass
class Superblock:
    """The content of one cell of the arterial grid."""

    index: tuple[int, int]
    corners: np.ndarray
    kind: str
    dong: int
    buildings: list[Building] = field(default_factory=list)
    roads: list[InnerRoad] = field(default_factory=list)
    ground: list[tuple[np.ndarray, int]] = field(default_factory=list)
    trees: list[tuple[float, float, float]] = field(default_factory=list)


class _Quad:
    """Bilinear parameter space (a, b) ∈ [0, 1]² over a convex quad; iso-lines are straight."""

    def __init__(self, q: np.ndarray):
        self.q = q
        self._corners = [(float(x), float(y)) for x, y in q]
        self.la = float(0.5 * (np.linalg.norm(q[1] - q[0]) + np.linalg.norm(q[2] - q[3])))
        self.lb = float(0.5 * (np.linalg.norm(q[3] - q[0]) + np.linalg.norm(q[2] - q[1])))

    def rolled(self, r: int) -> _Quad:
        """The same quad with its corners renumbered so that side ``r`` becomes side 0."""
        return _Quad(np.roll(self.q, -r, axis=0))

    def ring(self, ab: list[tuple[float, float]]) -> np.ndarray:
        """Closed world ring through parameter points (CCW in, CCW out).

        Plain float arithmetic: rings have a handful of points, where numpy's call overhead
        dominates; the same (a, b) always yields the same bits, so shared walls share vertices.
        """
        (x0, y0), (x1, y1), (x2, y2), (x3, y3) = self._corners
        pts = []
        for a, b in ab:
            w0, w1, w2, w3 = (1 - a) * (1 - b), a * (1 - b), a * b, (1 - a) * b
            pts.append((w0 * x0 + w1 * x1 + w2 * x2 + w3 * x3, w0 * y0 + w1 * y1 + w2 * y2 + w3 * y3))
        pts.append(pts[0])
        return np.array(pts)

    def rect(self, a0: float, a1: float, b0: float, b1: float) -> np.ndarray:
        return self.ring([(a0, b0), (a1, b0), (a1, b1), (a0, b1)])

    def l_shape(self, a0: float, a1: float, b0: float, b1: float, corner: int, fa: float, fb: float) -> np.ndarray:
        """A rectangle with the ``corner`` (0..3 CCW from (a0, b0)) notched by fractions fa × fb."""
        pts = [(a0, b0), (a1, b0), (a1, b1), (a0, b1)]
        ac, bc = pts[corner]
        am = ac + (fa * (a1 - a0) if ac == a0 else -fa * (a1 - a0))
        bm = bc + (fb * (b1 - b0) if bc == b0 else -fb * (b1 - b0))
        along_a_first = corner in (1, 3)  # the edge arriving at corners 1 and 3 runs along a
        notch = [(am, bc), (am, bm), (ac, bm)] if along_a_first else [(ac, bm), (am, bm), (am, bc)]
        return self.ring(pts[:corner] + notch + pts[corner + 1:])


def _orient(quad: _Quad, frontage, east_west: bool = False) -> tuple[_Quad, tuple]:
    """Renumber corners so that a runs along the long side (or the side nearest east–west)."""
    if east_west:
        d = quad.q[1] - quad.q[0]
        r = 0 if abs(d[0]) >= abs(d[1]) else 1
    else:
        r = 0 if quad.la >= quad.lb else 1
    return quad.rolled(r), tuple(np.roll(frontage, -r))


def _cuts(length: float, widths: tuple[float, float], rng: random.Random) -> np.ndarray:
    """Parcel boundaries along a side of ``length`` m as fractions 0..1."""
    edges = [0.0]
    while length - edges[-1] > widths[1] + widths[0]:
        edges.append(edges[-1] + rng.uniform(*widths))
    edges.append(length)
    return np.array(edges) / length


def _house(rng: random.Random) -> tuple[str, int, int, int]:
    """Use, floors, basements and roof for a villa-quarter building."""
    r = rng.random()
    if r < 0.45:
        return MULTIPLEX, rng.choice([3, 4, 4, 5, 5]), int(rng.random() < 0.5), \
            rng.choice([ROOF_GREEN, ROOF_CONCRETE, ROOF_CONCRETE, ROOF_WHITE])
    if r < 0.70:
        return MULTI_HOUSEHOLD, rng.randrange(2, 5), int(rng.random() < 0.4), \
            rng.choice([ROOF_GREEN, ROOF_CONCRETE, ROOF_BLUE_METAL])
    if r < 0.92:
        return DETACHED_HOUSE, rng.randrange(1, 3), int(rng.random() < 0.2), \
            rng.choice([ROOF_RED_TILE, ROOF_BROWN_TILE, ROOF_RED_TILE, ROOF_GREEN, ROOF_CONCRETE])
    return rng.choice((RETAIL, RESTAURANT)), rng.randrange(2, 5), rng.randrange(0, 2), \
        rng.choice([ROOF_CONCRETE, ROOF_GREEN])


def _shop(rng: random.Random, tall: bool) -> tuple[str, int, int, int]:
    if tall and rng.random() < 0.35:
        return OFFICE, rng.randrange(5, 13), rng.randrange(1, 4), rng.choice([ROOF_CONCRETE, ROOF_DARK])
    return rng.choice((RETAIL, RESTAURANT, RETAIL)), rng.randrange(2, 7 if tall else 5), \
        rng.randrange(0, 3), rng.choice([ROOF_CONCRETE, ROOF_GREEN, ROOF_CONCRETE, ROOF_BLUE_METAL])


def _fill_row(quad: _Quad, b0: float, b1: float, front_low: bool, shops: bool, tall: bool, block: int,
              sub0: int, rng: random.Random, sb: Superblock) -> int:
    """One row of parcels between b0 and b1 facing b0 (``front_low``) or b1; returns the next sub.

    Runs of neighbours share walls: their common side is the same parameter line, so both
    footprints get the very same vertices.
    """
    cuts = _cuts(quad.la, (8.0, 14.0) if shops else (9.0, 15.0), rng)
    depth_m = (b1 - b0) * quad.lb
    sub = sub0
    k = 0
    while k < len(cuts) - 1:
        run = rng.randrange(3, 8) if shops else (rng.randrange(2, 5) if rng.random() < 0.3 else 1)
        run = min(run, len(cuts) - 1 - k)
        front = rng.uniform(1.0, 2.5) / quad.lb
        rear = rng.uniform(0.8, 2.0) / quad.lb
        depth = min(depth_m - (front + rear) * quad.lb, rng.uniform(16.0, 20.0) if shops else rng.uniform(11.0, 16.0))
        if depth < 6.0:
            return sub
        depth /= quad.lb
        bb0, bb1 = (b0 + front, b0 + front + depth) if front_low else (b1 - front - depth, b1 - front)
        side = rng.uniform(0.6, 1.2) / quad.la
        spec = _shop(rng, tall) if shops else _house(rng)
        for n in range(run):
            a0 = cuts[k + n] + (side if n == 0 else 0.0)
            a1 = cuts[k + n + 1] - (side if n == run - 1 else 0.0)
            if (a1 - a0) * quad.la < 5.0:
                continue
            use, floors, under, roof = spec
            if run > 1 and not shops and use in (DETACHED_HOUSE, MULTI_HOUSEHOLD):
                use = ROW_HOUSE
            if run == 1 and use != DETACHED_HOUSE and rng.random() < 0.14:
                rear_corners = (2, 3) if front_low else (0, 1)
                ring = quad.l_shape(a0, a1, bb0, bb1, rear_corners[rng.randrange(2)],
                                    rng.uniform(0.3, 0.5), rng.uniform(0.3, 0.5))
            else:
                ring = quad.rect(a0, a1, bb0, bb1)
            sub += 1
            name = ""
            if use == MULTIPLEX and rng.random() < 0.25:
                name = rng.choice(VILLA_NAMES)
            sb.buildings.append(Building([ring], use, floors, under, roof, block, sub, name, detached=run == 1))
        k += run
    return sub


def _fill_villa(quad: _Quad, frontage, block: int, dong: int, rng: random.Random, sb: Superblock) -> None:
    quad, frontage = _orient(quad, frontage)
    rows = [(0.0, 0.5, True), (0.5, 1.0, False)] if quad.lb >= 27.0 else [(0.0, 1.0, True)]
    sub = 0
    for b0, b1, front_low in rows:
        shops = bool(frontage[0 if front_low else 2])
        sub = _fill_row(quad, b0, b1, front_low, shops, shops, block, sub, rng, sb)
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_LANE))


def _fill_commercial(quad: _Quad, frontage, block: int, dong: int, rng: random.Random,
                     sb: Superblock) -> None:
    quad, frontage = _orient(quad, frontage)
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_LANE))
    split = 0.55 if quad.lb >= 45.0 else 1.0
    cuts = _cuts(quad.la, (22.0, 40.0), rng)
    sub = 0
    for a0, a1 in zip(cuts[:-1], cuts[1:]):
        gap = rng.uniform(1.5, 3.0) / quad.la
        front = rng.uniform(3.0, 6.0) / quad.lb
        depth = min(split * quad.lb - rng.uniform(2.0, 4.0) - front * quad.lb, rng.uniform(18.0, 30.0)) / quad.lb
        wa, wb = (a1 - a0 - 2 * gap) * quad.la, depth * quad.lb
        if wa < 10.0 or wb < 8.0:
            continue
        rect = (a0 + gap, a1 - gap, front, front + depth)
        office = rng.random() < 0.6
        use = OFFICE if office else rng.choice((RETAIL, RESTAURANT))
        floors = rng.randrange(5, 16) if office else rng.randrange(3, 8)
        r = rng.random()
        if r < 0.12 and wa >= 26.0 and wb >= 22.0:
            rings = [quad.rect(*rect)]
            ha, hb = 0.3 * (rect[1] - rect[0]), 0.3 * (rect[3] - rect[2])
            hole = quad.rect(rect[0] + ha, rect[1] - ha, rect[2] + hb, rect[3] - hb)[::-1]
            rings.append(hole)
        elif r < 0.32:
            rings = [quad.l_shape(*rect, rng.choice([2, 3]), rng.uniform(0.35, 0.55), rng.uniform(0.35, 0.55))]
        else:
            rings = [quad.rect(*rect)]
        prefix, prefix_eng = rng.choice(OFFICE_PREFIXES)
        suffix, suffix_eng = rng.choice(OFFICE_SUFFIXES)
        name, eng = (f"{prefix}{suffix}", f"{prefix_eng} {suffix_eng}") if office or rng.random() < 0.3 else ("", "")
        sub += 1
        sb.buildings.append(Building(rings, use, floors, rng.randrange(2, 6) if office else rng.randrange(1, 3),
                                     rng.choice([ROOF_CONCRETE, ROOF_DARK, ROOF_WHITE]), block, sub, name,
                                     eng=eng))
    if split < 1.0:
        _fill_row(quad, split, 1.0, False, True, True, block, sub, rng, sb)


def _fill_culture(quad: _Quad, frontage, block: int, dong: int, rng: random.Random, sb: Superblock) -> None:
    """A performance hall on a plaza."""
    quad, frontage = _orient(quad, frontage)
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_LANE))
    ma, mb = min(0.3, 12.0 / quad.la), min(0.3, 10.0 / quad.lb)
    stem, stem_eng = dong_stem(dong)
    sb.buildings.append(Building([quad.rect(ma, 1 - ma, mb, 1 - mb)], PERFORMANCE_HALL, rng.randrange(2, 5), 1,
                                 ROOF_WHITE, block, 0, f"{stem}문화예술회관", eng=f"{stem_eng} Arts Center"))
    for _ in range(int(quad.la * quad.lb / 400)):
        a, b = rng.random(), rng.random()
        sb.trees.append((*quad.ring([(a, b)])[0], rng.uniform(2.0, 3.5)))


def _fill_apartment(quad: _Quad, frontage, block: int, dong: int, rng: random.Random,
                    sb: Superblock) -> None:
    """An apartment complex (단지): rows of slabs or towers facing south, a shop and an office."""
    quad, frontage = _orient(quad, frontage, east_west=True)
    stem, stem_eng = dong_stem(dong)
    brand, brand_eng = rng.choice(APT_BRANDS)
    name, eng = f"{stem}{brand}아파트", f"{stem_eng} {brand_eng} Apt."
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_LAWN))
    la, lb = quad.la, quad.lb
    margin = rng.uniform(12.0, 18.0)
    if la < 2 * margin + 40 or lb < 2 * margin + 40:
        _fill_park(quad, frontage, block, dong, rng, sb)
        return
    towers = rng.random() < 0.4
    # front strip (south or first side): commercial wing and management office
    shop_len = min(rng.uniform(25.0, 40.0), la - 2 * margin - 30.0)
    b_shop = (margin / lb, (margin + 14.0) / lb)
    sb.buildings.append(Building([quad.rect(margin / la, (margin + shop_len) / la, *b_shop)], RETAIL,
                                 rng.randrange(2, 4), 1, ROOF_CONCRETE, block, 0, name, "상가동", eng))
    sb.buildings.append(Building([quad.rect((la - margin - 14.0) / la, (la - margin) / la, b_shop[0],
                                            (margin + 10.0) / lb)], APARTMENT, 2, 0, ROOF_GREEN, block, 0, name,
                                 "관리동", eng))
    b = margin + 14.0 + rng.uniform(18.0, 26.0)
    dong_no = 101
    old = rng.random() < 0.5
    while True:
        floors = rng.randrange(18, 26) if towers else (rng.randrange(12, 16) if old else
                                                            rng.randrange(15, 26))
        depth = rng.uniform(20.0, 26.0) if towers else rng.uniform(11.0, 14.0)
        if b + depth > lb - margin:
            break
        length = rng.uniform(22.0, 30.0) if towers else rng.uniform(48.0, 90.0)
        gap = rng.uniform(16.0, 26.0)
        count = int((la - 2 * margin + gap) // (length + gap))
        if count < 1:
            break
        start = margin + (la - 2 * margin - count * length - (count - 1) * gap) / 2
        for n in range(count):
            a0 = (start + n * (length + gap)) / la
            a1 = a0 + length / la
            bb = (b / lb, (b + depth) / lb)
            if towers and rng.random() < 0.35:
                ring = quad.l_shape(a0, a1, *bb, rng.randrange(4), rng.uniform(0.35, 0.45), rng.uniform(0.35, 0.45))
            else:
                ring = quad.rect(a0, a1, *bb)
            sb.buildings.append(Building([ring], APARTMENT, floors, rng.randrange(1, 4),
                                         rng.choice([ROOF_CONCRETE, ROOF_WHITE, ROOF_CONCRETE]),
                                         block, 0, name, f"{dong_no}동", eng))
            dong_no += 1
        spacing = max(26.0, 0.8 * floors * 2.8)
        park_b0 = b + depth + 5.0
        if park_b0 + 12.0 < lb - margin:
            sb.ground.append((quad.rect(margin / la, 1 - margin / la, park_b0 / lb, (park_b0 + 12.0) / lb),
                              GROUND_PARKING))
        b += depth + spacing
    for _ in range(int(la * lb / 260)):
        tree_a, tree_b = rng.random(), rng.random()
        sb.trees.append((*quad.ring([(tree_a, tree_b)])[0], rng.uniform(2.0, 3.8)))


def _fill_school(quad: _Quad, frontage, block: int, dong: int, rng: random.Random, sb: Superblock) -> None:
    """An L-shaped school building along the back, a gym, and a bare sports ground in front."""
    quad, frontage = _orient(quad, frontage, east_west=True)
    la, lb = quad.la, quad.lb
    m = 8.0
    if la < 110 or lb < 90:
        _fill_apartment(quad, frontage, block, dong, rng, sb)
        return
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_LAWN))
    stem, stem_eng = dong_stem(dong)
    level, level_eng, code = rng.choice(SCHOOLS)
    name, eng = f"{stem}{level}", f"{stem_eng} {level_eng}"
    wing = 16.0
    top, mid, leg = (lb - m) / lb, (lb - m - wing) / lb, max((lb - m - wing - 45.0) / lb, 0.45)
    ring = quad.ring([(m / la, leg), ((m + wing) / la, leg), ((m + wing) / la, mid), (1 - m / la, mid),
                      (1 - m / la, top), (m / la, top)])
    sb.buildings.append(Building([ring], code, rng.randrange(4, 6), 1, ROOF_CONCRETE, block, 0, name, "본관",
                                 eng))
    gym = ((la - m - 32.0) / la, 1 - m / la, (lb - m - wing - 30.0) / lb, (lb - m - wing - 8.0) / lb)
    sb.buildings.append(Building([quad.rect(*gym)], code, 2, 0, ROOF_BLUE_METAL, block, 0, name, "체육관", eng))
    field_b0 = max(m, lb - m - wing - 10.0 - 70.0)
    field_rect = ((m + wing + 8.0) / la, min(la - m - 40.0, m + wing + 8.0 + 110.0) / la, field_b0 / lb,
                  (lb - m - wing - 10.0) / lb)
    sb.ground.append((quad.rect(*field_rect), GROUND_BARE))
    for _ in range(int(la * lb / 600)):
        a, b = rng.random(), rng.random() * field_b0 / lb
        sb.trees.append((*quad.ring([(a, b)])[0], rng.uniform(2.0, 3.5)))


def _fill_park(quad: _Quad, frontage, block: int, dong: int, rng: random.Random, sb: Superblock) -> None:
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_LAWN))
    for _ in range(int(quad.la * quad.lb / 120)):
        a, b = rng.random(), rng.random()
        sb.trees.append((*quad.ring([(a, b)])[0], rng.uniform(2.0, 4.0)))


def _fill_forest(quad: _Quad, frontage, block: int, dong: int, rng: random.Random, sb: Superblock) -> None:
    sb.ground.append((quad.rect(0, 1, 0, 1), GROUND_FOREST))


_FILLERS = {"villa": _fill_villa, "commercial": _fill_commercial, "culture": _fill_culture,
            "apartment": _fill_apartment, "school": _fill_school, "park": _fill_park, "forest": _fill_forest}


def footprints(buildings: list[Building]) -> np.ndarray:
    """Shapely polygons (with courtyards) of the buildings, built in one vectorised call."""
    if not buildings:
        return np.array([], dtype=object)
    rings = [b.rings[0] for b in buildings]
    index = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
    polygons = shapely.polygons(shapely.linearrings(np.concatenate(rings), indices=index))
    for k, b in enumerate(buildings):
        if len(b.rings) > 1:
            polygons[k] = shapely.Polygon(b.rings[0], b.rings[1:])
    return polygons
