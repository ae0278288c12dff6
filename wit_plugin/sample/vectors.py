"""Road-name-address layers (TL_SPBD_BULD, TL_SPRD_MANAGE, TL_SCCO_EMD) from a city layout.

Attributes follow the juso.go.kr schema and its numbering rules: lot numbers per legal dong,
25-digit building management numbers, road-address numbers from the distance along the road in
20 m basic intervals (odd on the left, even on the right), local roads named "<road><n>길" after
the place where they branch off. A few features carry the defects real files have; which ones is
recorded. Written with our own writer in CP949 without ``.cpg``, EPSG:5179.
"""
from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from osgeo import osr

from ..infra.errors import InputError
from .blocks import Building, Superblock, footprints
from .gangnam import DONGS, PITCHED_ROOFS
from .layout import CityLayout
from .shapefile_writer import SHP_POLYGON, SHP_POLYLINE, Field, write_shapefile

SIG_CD = "11680"  # Gangnam-gu

BUILDING_FIELDS = (
    Field("BDTYP_CD", "C", 5), Field("BD_MGT_SN", "C", 25), Field("BSI_INT_SN", "N", 10),
    Field("BSI_ZON_NO", "C", 5), Field("BULD_MNNM", "N", 5), Field("BULD_NM", "C", 100),
    Field("BULD_NM_DC", "C", 100), Field("BULD_SE_CD", "C", 1), Field("BULD_SLNO", "N", 5),
    Field("BUL_DPN_SE", "C", 1), Field("BUL_ENG_NM", "C", 100), Field("BUL_MAN_NO", "N", 10),
    Field("EMD_CD", "C", 3), Field("EQB_MAN_SN", "N", 10), Field("GRO_FLO_CO", "N", 3), Field("LI_CD", "C", 2),
    Field("LNBR_MNNM", "N", 4), Field("LNBR_SLNO", "N", 4), Field("MNTN_YN", "C", 1), Field("NTFC_DE", "C", 8),
    Field("OPERT_DE", "C", 14), Field("POS_BUL_NM", "C", 40), Field("RDS_MAN_NO", "N", 12),
    Field("RDS_SIG_CD", "C", 5), Field("RN_CD", "C", 7), Field("SIG_CD", "C", 5), Field("UND_FLO_CO", "N", 3),
)
ROAD_FIELDS = (
    Field("ALWNC_DE", "C", 8), Field("ALWNC_RESN", "C", 254), Field("BSI_INT", "C", 5), Field("ENG_RN", "C", 80),
    Field("MVMN_DE", "C", 8), Field("MVMN_RESN", "C", 254), Field("MVM_RES_CD", "C", 10), Field("NTFC_DE", "C", 8),
    Field("OPERT_DE", "C", 14), Field("RBP_CN", "C", 80), Field("RDS_DPN_SE", "C", 1), Field("RDS_MAN_NO", "N", 12),
    Field("REP_CN", "C", 80), Field("RN", "C", 80), Field("RN_CD", "C", 7), Field("ROAD_BT", "N", 10, 3),
    Field("ROAD_LT", "N", 10, 3), Field("ROA_CLS_SE", "C", 2), Field("SIG_CD", "C", 5), Field("WDR_RD_CD", "C", 10),
)
DISTRICT_FIELDS = (Field("EMD_CD", "C", 10), Field("EMD_ENG_NM", "C", 40), Field("EMD_KOR_NM", "C", 40))

DEFECT_KINDS = ("unclosed_ring", "wrong_winding", "duplicate_vertex", "self_intersection", "sliver",
                "missing_floors")
_ADDRESS_ORIGIN = 3000.0  # m of road before the sample's grid origin, so numbers are not tiny
_MOVE_REASON = "광역도로 정비 및 부여사유, 부여방식 정비"


def esri_prj(epsg: int) -> str:
    """ESRI-flavoured WKT, as in real .prj files, that GDAL/QGIS still match to the EPSG code."""
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    srs.MorphToESRI()
    return srs.ExportToWkt()


@dataclass
class RoadFeature:
    """One road section: its centre line in the sample square and what addresses are counted from."""

    coords: np.ndarray
    width: float
    arterial: tuple | None  # ARTERIALS row, or None for a local road
    name: str
    eng: str
    rn_cd: str
    origin: np.ndarray  # address numbers count along ``axis`` from here
    axis: np.ndarray
    offset: float
    dong: int = -1  # legal dong a local road lies in (its start and end lots are described there)
    branch_no: int = 0


@dataclass
class VectorData:
    """The study-area vectors, ready to write."""

    center: np.ndarray
    half: float
    superblocks: list[Superblock]
    buildings: list[Building]
    owners: list[Superblock]  # the superblock of each building
    roads: list[RoadFeature] = field(default_factory=list)
    building_columns: dict[str, list] = field(default_factory=dict)
    building_rings: list[list[np.ndarray]] = field(default_factory=list)
    defects: dict[str, list[int]] = field(default_factory=dict)


def _square(center: np.ndarray, half: float) -> tuple[float, float, float, float]:
    return center[0] - half, center[1] - half, center[0] + half, center[1] + half


def _extent(building: Building, center: np.ndarray) -> float:
    """Chebyshev distance of the footprint's farthest vertex from the centre."""
    return float(np.abs(building.rings[0] - center).max())


def select(layout: CityLayout, half: float | None, n_buildings: int | None, density: float) -> VectorData:
    """Buildings lying wholly inside the square of half-size ``half``, or the ``n_buildings`` nearest.

    With ``n_buildings`` the square grows until it holds that many buildings: the half-size is
    the Chebyshev extent of the n-th nearest footprint. ``density`` (buildings per m²) is only
    the first guess of how far to look.
    """
    center = layout.center
    if n_buildings is None:
        if half is None:
            raise ValueError("select needs the half-size or the number of buildings")
        guess = half
    else:
        guess = 1.15 * float(np.sqrt(n_buildings / (4.0 * density))) + 300.0
    while True:
        superblocks = layout.superblocks(_square(center, guess))
        pairs = [(_extent(b, center), sb, b) for sb in superblocks for b in sb.buildings]
        extents = np.array([p[0] for p in pairs])
        if n_buildings is None:
            half = guess
            break
        if (extents <= guess).sum() >= n_buildings:
            half = float(np.sort(extents)[n_buildings - 1])
            break
        guess *= 1.3
    chosen = [(sb, b) for e, sb, b in pairs if e <= half]
    if not chosen:
        raise InputError(f"no building lies within {half:.0f} m of the centre; use a larger radius")
    box = shapely.box(*_square(center, half))
    keep = [sb for sb in superblocks if shapely.intersects(shapely.Polygon(sb.corners), box)]
    return VectorData(center, half, keep, [b for _, b in chosen], [sb for sb, _ in chosen])


def build_roads(layout: CityLayout, data: VectorData) -> None:
    """Arterials and inner roads clipped to the square, named and numbered like TL_SPRD_MANAGE."""
    box = shapely.box(*_square(layout.center, data.half))
    ii = sorted({sb.index[0] for sb in data.superblocks})
    jj = sorted({sb.index[1] for sb in data.superblocks})
    roads: list[RoadFeature] = []
    for family, indices, span in (("u", range(ii[0], ii[-1] + 2), (jj[0], jj[-1] + 1)),
                                  ("v", range(jj[0], jj[-1] + 2), (ii[0], ii[-1] + 1))):
        for index in indices:
            row = layout.arterial(family, index)
            origin = layout.node(index, 0) if family == "u" else layout.node(0, index)
            for part in (p for run in layout.arterial_runs(family, index, *span) for p in _clip(run, box)):
                roads.append(RoadFeature(part, row[3], row, row[0], row[1], row[2], origin, layout.axis(family),
                                         _ADDRESS_ORIGIN))
    taken: set[str] = set()
    for sb in data.superblocks:
        for inner in sb.roads:
            parts = _clip(inner.coords, box)
            if not parts:
                continue
            family, index = inner.parent
            parent = layout.arterial(family, index)
            parent_origin = layout.node(index, 0) if family == "u" else layout.node(0, index)
            along = float(np.dot(inner.coords[0] - parent_origin, layout.axis(family))) + _ADDRESS_ORIGIN
            number = max(1, 2 * int(along // 20.0)) + (1 if family == "v" else 2)
            while f"{parent[0]}{number}길" in taken:
                number += 2
            taken.add(f"{parent[0]}{number}길")
            direction = inner.coords[-1] - inner.coords[0]
            for part in parts:
                roads.append(RoadFeature(part, inner.width, None, f"{parent[0]}{number}길",
                                         f"{parent[1]} {number}-gil", "", inner.coords[0],
                                         direction / np.linalg.norm(direction), 0.0, sb.dong, number))
    local_codes = iter(range(4166100, 4170000))
    codes: dict[str, str] = {}
    for road in roads:
        if road.arterial is None:
            road.rn_cd = codes.setdefault(road.name, str(next(local_codes)))
    data.roads = roads


def _clip(coords: np.ndarray, box) -> list[np.ndarray]:
    clipped = shapely.intersection(shapely.LineString(coords), box)
    parts = [clipped] if clipped.geom_type == "LineString" else list(getattr(clipped, "geoms", []))
    return [np.asarray(p.coords) for p in parts if p.geom_type == "LineString" and p.length > 1.0]


def road_columns(data: VectorData, rng: np.random.Generator) -> dict[str, list]:
    cols: dict[str, list] = {f.name: [] for f in ROAD_FIELDS}
    for number, road in enumerate(data.roads, start=1):
        if road.arterial is not None:
            rn, eng, rn_cd, width, length, cls, wdr, alwnc_de, reason, ntfc, rbp, rep = road.arterial
            bsi, mvmn_reason, mvm_code = "20", "직권수정(속성변경)", "99"
        else:
            length = round(float(shapely.LineString(road.coords).length), 3)
            rn, eng, rn_cd, width, cls, wdr = road.name, road.eng, road.rn_cd, road.width, "4", "3"
            alwnc_de, ntfc = "20101018", "20101203"
            dong_kor, lot = DONGS[road.dong][2], DONGS[road.dong][5] + int(rng.integers(0, 60))
            reason = f"{road.name[:-len(str(road.branch_no)) - 1]} 시점에서 {road.branch_no}번째 분기된 도로"
            rbp, rep = f"{dong_kor} {lot}-{int(rng.integers(1, 30))}", f"{dong_kor} {lot + int(rng.integers(1, 40))}"
            bsi, mvmn_reason, mvm_code = str(int(rng.choice([12, 13, 14, 15, 16, 20]))), _MOVE_REASON, "90"
        values = dict(ALWNC_DE=alwnc_de, ALWNC_RESN=reason, BSI_INT=bsi, ENG_RN=eng, MVMN_DE="20141030",
                      MVMN_RESN=mvmn_reason, MVM_RES_CD=mvm_code, NTFC_DE=ntfc,
                      OPERT_DE=f"20141030{int(rng.integers(90000, 235959)):06d}", RBP_CN=rbp, RDS_DPN_SE="0",
                      RDS_MAN_NO=number, REP_CN=rep, RN=rn, RN_CD=rn_cd, ROAD_BT=width, ROAD_LT=length,
                      ROA_CLS_SE=cls, SIG_CD=SIG_CD, WDR_RD_CD=wdr)
        for key, value in values.items():
            cols[key].append(value)
    return cols


def building_columns(data: VectorData, rng: np.random.Generator) -> None:
    """Lots, management numbers, road addresses and dates for every selected building."""
    buildings, owners = data.buildings, data.owners
    rank = {sb.index: k for k, sb in enumerate(data.superblocks)}
    lots: dict[tuple, int] = {}
    next_lot = {d: DONGS[d][5] for d in range(len(DONGS))}
    serials: dict[tuple, int] = {}
    eqb = {d: 0 for d in range(len(DONGS))}
    points = shapely.point_on_surface(footprints(buildings))
    tree = shapely.STRtree([shapely.LineString(r.coords) for r in data.roads])
    nearest = tree.query_nearest(points, all_matches=False)[1]
    used_numbers: dict[tuple, int] = {}
    group_address: dict[tuple, tuple] = {}
    cols: dict[str, list] = {f.name: [] for f in BUILDING_FIELDS}
    for k, (b, sb) in enumerate(zip(buildings, owners)):
        dong = sb.dong
        block_key = (sb.index, b.block)
        if block_key not in lots:
            lots[block_key] = next_lot[dong]
            next_lot[dong] += 1
        main = lots[block_key]
        parcel = (sb.index, b.block, b.sub)
        serials[parcel] = serials.get(parcel, 0) + 1
        eqb[dong] += 1
        if parcel not in group_address:
            road = data.roads[nearest[k]]
            p = np.array([points[k].x, points[k].y])
            rel = p - road.origin
            along = max(0.0, float(np.dot(rel, road.axis)) + road.offset)
            left = road.axis[0] * rel[1] - road.axis[1] * rel[0] > 0
            mnnm = max(1, 2 * int(along // 20.0) + (1 if left else 2))
            slno = used_numbers.get((road.rn_cd, mnnm), 0)
            used_numbers[(road.rn_cd, mnnm)] = slno + 1
            ntfc = datetime.date(2011, 7, 29) + datetime.timedelta(days=int(rng.integers(0, 3800)))
            opert = min(ntfc + datetime.timedelta(days=int(rng.integers(0, 1500))), datetime.date(2022, 12, 30))
            group_address[parcel] = (nearest[k], mnnm, slno, int(along // 20.0), ntfc, opert)
        road_no, mnnm, slno, interval, ntfc, opert = group_address[parcel]
        rds_man_no = road_no + 1
        emd = DONGS[dong][0][5:]
        values = dict(
            BDTYP_CD=b.use, BD_MGT_SN=f"{SIG_CD}{emd}000{main:04d}{b.sub:04d}{serials[parcel]:06d}",
            BSI_INT_SN=rds_man_no * 1000 + interval % 1000, BSI_ZON_NO=f"{6000 + rank[sb.index] % 400:05d}",
            BULD_MNNM=mnnm, BULD_NM=b.name, BULD_NM_DC=b.name_dc, BULD_SE_CD="0", BULD_SLNO=slno, BUL_DPN_SE="0",
            BUL_ENG_NM=b.eng, BUL_MAN_NO=0, EMD_CD=emd, EQB_MAN_SN=eqb[dong], GRO_FLO_CO=b.floors, LI_CD="00",
            LNBR_MNNM=main, LNBR_SLNO=b.sub, MNTN_YN="0", NTFC_DE=ntfc.strftime("%Y%m%d"),
            OPERT_DE=opert.strftime("%Y%m%d") + f"{int(rng.integers(80000, 195959)):06d}",
            POS_BUL_NM=b.name, RDS_MAN_NO=rds_man_no, RDS_SIG_CD=SIG_CD, RN_CD=data.roads[road_no].rn_cd,
            SIG_CD=SIG_CD, UND_FLO_CO=b.under)
        for key, value in values.items():
            cols[key].append(value)
    data.building_columns = cols
    data.building_rings = [[r[::-1] for r in b.rings] for b in buildings]  # shapefile: exterior clockwise


def add_defects(data: VectorData, rng: np.random.Generator, per_kind: int = 3) -> None:
    """Give a few recorded buildings the defects of real files; slivers are extra features."""
    cols, rings = data.building_columns, data.building_rings
    simple = [k for k, b in enumerate(data.buildings)
              if b.detached and len(b.rings) == 1 and len(b.rings[0]) == 5 and b.roof not in PITCHED_ROOFS]
    per_kind = min(per_kind, len(simple) // len(DEFECT_KINDS))
    if per_kind == 0:
        raise InputError("the area is too small to hold sample defects; use a larger radius")
    picks = rng.permutation(simple)[: per_kind * len(DEFECT_KINDS)].reshape(len(DEFECT_KINDS), per_kind)
    defects: dict[str, list[int]] = {}
    for kind, ks in zip(DEFECT_KINDS, picks):
        for k in sorted(int(x) for x in ks):
            ring = rings[k][0]
            if kind == "unclosed_ring":
                rings[k][0] = ring[:-1]
            elif kind == "wrong_winding":
                rings[k][0] = ring[::-1]
            elif kind == "duplicate_vertex":
                rings[k][0] = np.vstack([ring[:2], ring[1:]])
            elif kind == "self_intersection":
                rings[k][0] = ring[[0, 2, 1, 3, 4]]
            elif kind == "missing_floors":
                cols["GRO_FLO_CO"][k] = 0 if len(defects.get(kind, [])) % 2 == 0 else None
            else:
                _append_sliver(data, k)
                k = len(rings) - 1
            defects.setdefault(kind, []).append(k)
    cols["BUL_MAN_NO"] = [10_000_001 + k for k in range(len(rings))]
    data.defects = {kind: [cols["BUL_MAN_NO"][k] for k in ks] for kind, ks in defects.items()}


def _append_sliver(data: VectorData, host: int) -> None:
    """A 3 cm strip along the host's first wall, inside it: a digitising leftover (< 1 m²)."""
    ring = data.building_rings[host][0]
    p0, p1 = ring[0], ring[1]
    d = p1 - p0
    length = float(np.linalg.norm(d))
    inward = np.array([d[1], -d[0]]) / length  # right of travel on a clockwise ring
    width = min(0.03, 0.9 / length)
    sliver = np.array([p0, p1, p1 + inward * width, p0 + inward * width, p0])
    data.building_rings.append([sliver])
    cols = data.building_columns
    for values in cols.values():
        values.append(values[host])
    mgt = cols["BD_MGT_SN"][host]
    cols["BD_MGT_SN"][-1] = mgt[:19] + f"{int(mgt[19:]) + 500:06d}"
    for key in ("BULD_NM", "BULD_NM_DC", "BUL_ENG_NM", "POS_BUL_NM"):
        cols[key][-1] = ""


def district_layer(data: VectorData) -> tuple[list[list[np.ndarray]], dict[str, list]]:
    """Legal dongs as unions of their superblocks (boundaries on arterial centre lines)."""
    by_dong: dict[int, list] = {}
    for sb in data.superblocks:
        by_dong.setdefault(sb.dong, []).append(shapely.Polygon(sb.corners))
    square = shapely.box(*_square(data.center, data.half))
    geoms: list = []
    cols: dict[str, list] = {f.name: [] for f in DISTRICT_FIELDS}
    for dong in sorted(by_dong, key=lambda d: DONGS[d][0]):
        shape = shapely.orient_polygons(shapely.intersection(shapely.union_all(by_dong[dong]), square),
                                        exterior_cw=True)
        polygons = [shape] if shape.geom_type == "Polygon" else [g for g in shape.geoms if g.geom_type == "Polygon"]
        polygons = [p for p in polygons if p.area > 1.0]
        if not polygons:
            continue
        geoms.append([np.asarray(r.coords) for p in polygons for r in (p.exterior, *p.interiors)])
        code, eng, kor, *_ = DONGS[dong]
        for key, value in (("EMD_CD", code), ("EMD_ENG_NM", eng), ("EMD_KOR_NM", kor)):
            cols[key].append(value)
    return geoms, cols


def write_layers(folder: Path, data: VectorData, rng: np.random.Generator) -> dict[str, int]:
    """Write the three shapefiles into ``folder``; returns feature counts."""
    prj = esri_prj(5179)
    write_shapefile(folder / "TL_SPBD_BULD", SHP_POLYGON, data.building_rings, BUILDING_FIELDS,
                    data.building_columns, prj)
    write_shapefile(folder / "TL_SPRD_MANAGE", SHP_POLYLINE, [[r.coords] for r in data.roads], ROAD_FIELDS,
                    road_columns(data, rng), prj)
    districts, district_cols = district_layer(data)
    write_shapefile(folder / "TL_SCCO_EMD", SHP_POLYGON, districts, DISTRICT_FIELDS, district_cols, prj)
    return {"buildings": len(data.building_rings), "roads": len(data.roads), "districts": len(districts)}
