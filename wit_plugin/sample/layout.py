"""Synthetic Gangnam-like city layout: street grid, blocks, parcels and building footprints.

The layout imitates south-east Seoul: a slightly rotated grid of arterial roads (30–50 m)
around superblocks of 300–650 m; inside them villa quarters cut by 6–12 m lanes, commercial
blocks along collectors, apartment complexes (단지) with slab or tower blocks facing south,
schools, parks, and forest on the hills (대모산, 구룡산). Blocks are the road cells inset by
half the road width plus a sidewalk, so roads never run through buildings.

Every superblock is generated from its own random stream keyed by (seed, i, j), so the content
of a place does not depend on how large an area is requested: the study area and the wider
orthoimage footprint see the same city.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

import numpy as np
import shapely
from pyproj import Transformer

# Real Gangnam-gu legal dongs (TL_SCCO_EMD): code, English and Korean names, the dong's centroid
# as an offset in metres (EPSG:5179) from Suseo station, and the first lot number we hand out.
DONGS = (
    ("11680101", "Yeoksam-dong", "역삼동", -5603, 1410, 600),
    ("11680103", "Gaepo-dong", "개포동", -3488, -797, 1200),
    ("11680104", "Cheongdam-dong", "청담동", -4536, 4103, 1),
    ("11680105", "Samseong-dong", "삼성동", -4042, 2944, 1),
    ("11680106", "Daechi-dong", "대치동", -3411, 1301, 500),
    ("11680107", "Sinsa-dong", "신사동", -6654, 4048, 500),
    ("11680108", "Nonhyeon-dong", "논현동", -6199, 2922, 1),
    ("11680110", "Apgujeong-dong", "압구정동", -6476, 4816, 300),
    ("11680111", "Segok-dong", "세곡동", 219, -2578, 100),
    ("11680112", "Jagok-dong", "자곡동", -151, -1257, 200),
    ("11680113", "Yulhyeon-dong", "율현동", 883, -1866, 50),
    ("11680114", "Irwon-dong", "일원동", -1692, 53, 600),
    ("11680115", "Suseo-dong", "수서동", -468, -189, 700),
    ("11680118", "Dogok-dong", "도곡동", -5014, 133, 400),
)
SUSEO_DONG = 12
SUSEO_STATION_5179 = (964814.8599, 1943225.0080)  # 127.1020°E 37.4876°N on Korea 2000

# Real Gangnam-gu roads (TL_SPRD_MANAGE, 2019) used for the arterial grid, nearest first:
# RN, ENG_RN, RN_CD, ROAD_BT, ROAD_LT, ROA_CLS_SE, WDR_RD_CD, ALWNC_DE, ALWNC_RESN, NTFC_DE, RBP_CN, REP_CN.
ARTERIALS = (
    ("밤고개로", "Bamgogae-ro", "3122003", 30.0, 3592.0, "3", "3", "20090701",
     "율현동의 순수 우리말인 밤고개를 인용하여 제정", "20090710", "수서동 725", "세곡동 151-14"),
    ("광평로", "Gwangpyeong-ro", "3122002", 30.0, 3334.0, "3", "3", "20100419",
     "광평대군의 묘역이 위치하여 묘역의 명칭을 사용하여 제정", "20100420", "일원동 702-11", "수서동 718"),
    ("남부순환로", "Nambusunhwan-ro", "2000003", 41.0, 32620.0, "2", "1", "20090710",
     "서울의 남쪽을 연결하는 도로", "20100315", "강서구 방화동 434-10", "강남구 수서동 329-21"),
    ("자곡로", "Jagok-ro", "3122014", 35.0, 3010.769, "3", "3", "20120607", "자곡동 명칭 인용", "20120615",
     "세곡동 산52-40", "자곡동 45"),
    ("헌릉로", "Heolleung-ro", "3000033", 35.0, 10907.0, "3", "1", "20090701", "헌인릉의 지역적 특성을 부여",
     "20090710", "서초구 양재동 238-1", "성남시 수정구 신흥동 8-4"),
    ("분당수서로", "Bundangsuseo-ro", "3180055", 30.0, 25338.0, "3", "1", "20090710", "분당 수서간 자동차전용도로",
     "20090710", "성남시 분당구 구미동 174", "광진구 자양동 97-5"),
    ("양재대로", "Yangjae-daero", "2000006", 50.0, 19360.0, "2", "1", "20100310", "지역명 사용", "20180308",
     "서울 서초구 중앙로 626", "경기 구리시 강변북로 224"),
    ("삼성로", "Samseong-ro", "3122005", 35.0, 5061.0, "3", "3", "20100419", "삼성동 행정구역명을 인용하여  제정",
     "20100422", "개포동 191", "청담동 48"),
    ("도곡로", "Dogok-ro", "3122012", 40.0, 4700.0, "3", "2", "20100422", "행정구역 명칭 사용", "20100422",
     "서울특별시 강남구 도곡동 943(강남대로)", "서울특별시 송파구 잠실동 294 (백제고분로)"),
    ("봉은사로", "Bongeunsa-ro", "3122004", 35.0, 4200.0, "3", "3", "20100419",
     "강남개발 이전부터 존재하던 주요문화재 봉은사의 명칭을 인용", "20100422", "논현동 200-7", "삼성동 171-4"),
    ("언주로", "Eonju-ro", "3005086", 40.0, 12080.0, "3", "2", "20090701", "옛 지명 인용", "20090710",
     "서울특별시 서초구 내곡동 산12-431(인능산1자연공원)", "서울특별시 강남구 압구정동 480"),
    ("논현로", "Nonhyeon-ro", "3121022", 30.0, 8300.0, "3", "2", "20100520", "행정구역명칭 인용", "20100520",
     "서울특별시 서초구 양재동 402-6(양재대로)", "서울특별시 성동구 옥수동 487(동호대교 북단)"),
    ("테헤란로", "Teheran-ro", "3122010", 50.0, 3898.0, "2", "3", "20100419",
     "테헤란시와 서울시의 자매결연을 기념 상호 도시명을 도로명으로 제정", "20100422", "역삼동 821", "삼성동 171-3"),
    ("강남대로", "Gangnam-daero", "2102001", 50.0, 7820.0, "2", "2", "20090701", "행정구역 명칭 사용", "20090710",
     "서울특별시 서초구 양재동 238-1(염곡사거리)", "서울특별시 용산구 한남동 782(한강대교북단)"),
    ("압구정로", "Apgujeong-ro", "3122007", 30.0, 3041.0, "3", "3", "20100419", "행정구역 명칭 적용", "20100422",
     "압구정동 408", "청담동 119-2"),
    ("도산대로", "Dosan-daero", "2122001", 50.0, 3262.0, "2", "3", "20080901",
     "일제시대 독립운동가인 안창호 선생의 호 도산을 인용, 도산대로변에는 도산의 묘원인 도산공원이 위치함", "20080926",
     "강남구 신사동 501-2", "청담동 130"),
    ("학동로", "Hakdong-ro", "3122011", 40.0, 3755.0, "3", "3", "20100419",
     "본래 학로였으나 1984년 11월 7일 가로명 제정때 학동로로 부여", "20100422", "논현동 50-2", "청담동 134-18"),
    ("일원로", "Irwon-ro", "3122009", 25.0, 1430.0, "3", "3", "20080901",
     "이 노선이 지나는 일원동의 행정구역명을 적용하여 제정", "20101203", "일원동 618-3", "일원동 738"),
    ("개포로", "Gaepo-ro", "3122001", 20.0, 4526.0, "3", "3", "20100419",
     "이 노선이 지나는 개포동의 행정구역명을 적용하여 제정", "20100422", "개포동 1239-18", "일원동 644-11"),
    ("선릉로", "Seolleung-ro", "3122006", 25.0, 6352.0, "3", "3", "20080901",
     "조선 제9대 왕인 성종과 성종의 계비 정현왕후의 능인 선릉에서 유래", "20101203", "개포동 567-22", "압구정동 510"),
    ("역삼로", "Yeoksam-ro", "3122008", 20.0, 3607.0, "3", "3", "20100419", "행정구역 명칭 적용", "20100422",
     "역삼동 831-16", "대치동 1004-3"),
    ("양재천로", "Yangjaecheon-ro", "3121023", 20.0, 4500.0, "3", "2", "20100419", "양재천 명칭 인용", "20100422",
     "서울특별시 서초구 우면동 23-14(경부고속도로 하부)", "서울특별시 강남구 대치동 513(영동대로)"),
)

# Building-use codes (건축물 용도코드, BDTYP_CD).
DETACHED_HOUSE, MULTI_HOUSEHOLD, APARTMENT, ROW_HOUSE, MULTIPLEX = "01001", "01003", "02001", "02002", "02003"
RETAIL, RESTAURANT, PERFORMANCE_HALL, OFFICE = "03001", "04001", "05001", "14201"
SCHOOLS = (("초등학교", "Elementary School", "10101"), ("중학교", "Middle School", "10102"),
           ("고등학교", "High School", "10103"))

# Roof styles, drawn by the orthoimage renderer.
ROOF_CONCRETE, ROOF_GREEN, ROOF_RED_TILE, ROOF_BROWN_TILE, ROOF_BLUE_METAL, ROOF_WHITE, ROOF_DARK = range(7)
PITCHED_ROOFS = (ROOF_RED_TILE, ROOF_BROWN_TILE)

# Ground classes, drawn by the orthoimage renderer (0 is sidewalk / paving, the background).
GROUND_LAWN, GROUND_FOREST, GROUND_BARE, GROUND_PARKING, GROUND_LANE = 1, 2, 3, 4, 5

_APT_BRANDS = (("삼익", "Samik"), ("신동아", "Sindonga"), ("한아름", "Hanareum"), ("까치마을", "Kkachimaeul"),
               ("현대", "Hyundai"), ("우성", "Woosung"), ("래미안", "Raemian"), ("푸르지오", "Prugio"),
               ("자이", "Xi"), ("힐스테이트", "Hillstate"), ("롯데캐슬", "Lotte Castle"), ("더샵", "The Sharp"),
               ("아이파크", "I-Park"), ("쌍용", "Ssangyong"), ("한신", "Hanshin"), ("상록수", "Sangroksu"),
               ("목련타운", "Mongnyeon Town"), ("청솔", "Cheongsol"), ("푸른마을", "Pureun Maeul"),
               ("데시앙포레", "Desian Foret"), ("강남힐즈", "Gangnam Hills"), ("샘터마을", "Saemteo Maeul"))
_OFFICE_PREFIXES = (("대원", "Daewon"), ("한솔", "Hansol"), ("동아", "Donga"), ("세방", "Sebang"), ("KT", "KT"),
                    ("신한", "Shinhan"), ("삼환", "Samhwan"), ("대림", "Daelim"), ("광림", "Gwangrim"),
                    ("유니온", "Union"), ("에이스", "Ace"), ("SRT", "SRT"), ("현대", "Hyundai"), ("금강", "Geumgang"))
_OFFICE_SUFFIXES = (("빌딩", "Bldg."), ("타워", "Tower"), ("프라자", "Plaza"), ("센터", "Center"))
_VILLA_NAMES = ("그린빌라", "한양빌라", "세림하이츠", "삼성맨션", "동원빌라", "대림하우스", "우정빌라", "청구빌라",
                "해오름빌", "수정캐슬", "라움하우스", "예림빌")


def dong_stem(index: int) -> tuple[str, str]:
    """Korean and English dong name without the 동/-dong suffix, e.g. ('수서', 'Suseo')."""
    _, eng, kor, *_ = DONGS[index]
    return kor[:-1], eng[: -len("-dong")]


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
        rng = random.Random(f"{self.seed}:{i}:{j}")  # stdlib: ~50x cheaper per draw than numpy here
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
        cell_heights = self._heights(np.array([c.mean(axis=0) for c, _, _ in cells])) if cells else []
        kinds = _cell_kinds(sb.kind, len(cells), rng)
        for block, ((cell, inset, frontage), h, cell_kind) in enumerate(zip(cells, cell_heights, kinds)):
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
    length_u = 0.5 * (np.linalg.norm(corners[1] - corners[0]) + np.linalg.norm(corners[2] - corners[3]))
    length_v = 0.5 * (np.linalg.norm(corners[3] - corners[0]) + np.linalg.norm(corners[2] - corners[1]))
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


class _Quad:
    """Bilinear parameter space (a, b) ∈ [0, 1]² over a convex quad; iso-lines are straight."""

    def __init__(self, q: np.ndarray):
        self.q = q
        self._corners = [(float(x), float(y)) for x, y in q]
        self.la = 0.5 * (np.linalg.norm(q[1] - q[0]) + np.linalg.norm(q[2] - q[3]))
        self.lb = 0.5 * (np.linalg.norm(q[3] - q[0]) + np.linalg.norm(q[2] - q[1]))

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
                name = rng.choice(_VILLA_NAMES)
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
        prefix, prefix_eng = rng.choice(_OFFICE_PREFIXES)
        suffix, suffix_eng = rng.choice(_OFFICE_SUFFIXES)
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
    brand, brand_eng = rng.choice(_APT_BRANDS)
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
        a, bb = rng.random(), rng.random()
        sb.trees.append((*quad.ring([(a, bb)])[0], rng.uniform(2.0, 3.8)))


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
