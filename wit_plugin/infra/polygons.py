"""Vectorised helpers on arrays of shapely geometries, shared by the vector steps.

Reprojection in one PROJ call, the polygonal parts of overlay results, OGC orientation, and the
repairs of ``repair_polygons``, counted per kind:

* ``unclosed_ring`` (OGR passes unclosed rings through; they are detected in the raw WKB and
  closed), ``orientation`` (exteriors made counter-clockwise, holes clockwise; shapefiles store
  exteriors clockwise, so nearly every shapefile feature counts), ``repeated_vertex`` (consecutive
  vertices closer than 1 mm merged), ``invalid`` (``make_valid``, method "structure", polygonal
  parts only), ``multipart`` (a repair split a feature, e.g. a bow-tie into two triangles: all parts
  are kept as one multi-part feature, so the building keeps its id and no area silently disappears)
  and ``sliver_part`` (a sliver part removed from a feature that has other parts).
* **Slivers**: a part is dropped when its area is below ``min_area`` (``too_small``) or when it is
  both thin (Polsby–Popper 4πA/P² < ``sliver_thinness``) and narrow (mean width 2A/P <
  ``sliver_width``) (``thin``). The width guard keeps real long buildings such as terraces.
  A feature left without parts is dropped with that reason.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pyproj
import shapely

from .io.vector_io import non_finite

REPAIR_KINDS = ("unclosed_ring", "orientation", "repeated_vertex", "invalid", "multipart", "sliver_part")
REPEATED_POINT_TOLERANCE = 0.001  # m


def transform(geoms: np.ndarray, source: pyproj.CRS, target: pyproj.CRS) -> np.ndarray:
    """Reproject a geometry array in one vectorised PROJ call."""
    if source.equals(target):
        return geoms
    tr = pyproj.Transformer.from_crs(source, target, always_xy=True)

    def _apply(coords: np.ndarray) -> np.ndarray:
        x, y = tr.transform(coords[:, 0], coords[:, 1])
        return np.column_stack([x, y])

    return shapely.transform(geoms, _apply)


def polygonal(geoms: np.ndarray) -> np.ndarray:
    """Keep only the polygonal parts (overlay and make_valid may add lines and points); None if none."""
    out = geoms.copy()
    mixed = np.flatnonzero(shapely.get_type_id(geoms) == 7)
    if len(mixed):
        parts, index = shapely.get_parts(geoms[mixed], return_index=True)
        keep = np.isin(shapely.get_type_id(parts), (3, 6))
        out[mixed] = None
        for i in np.unique(index[keep]):
            out[mixed[i]] = shapely.union_all(parts[keep & (index == i)])
    areal = np.isin(shapely.get_type_id(out), (3, 6)) & ~shapely.is_empty(out)
    out[~areal] = None
    return out


def _single_or_multi(parts: np.ndarray, index: np.ndarray, n: int) -> np.ndarray:
    """Regroup polygon parts into features: a Polygon for one part, a MultiPolygon for more."""
    out = np.full(n, None, dtype=object)
    if len(parts) == 0:
        return out
    counts = np.bincount(index, minlength=n)
    single = counts[index] == 1
    out[index[single]] = parts[single]
    multi = np.flatnonzero(counts > 1)
    if len(multi):
        sel = np.isin(index, multi)
        grouped = shapely.multipolygons(parts[sel], indices=np.searchsorted(multi, index[sel]))
        out[multi] = grouped
    return out


def orient(geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shells counter-clockwise, holes clockwise (OGC); also which features had a ring turned.

    Vectorised on the rings: ``shapely.orient_polygons`` is a Python loop when shapely runs on
    GEOS < 3.12 (as with the system GEOS that QGIS uses).
    """
    parts, part_of = shapely.get_parts(geoms, return_index=True)
    rings, ring_of = shapely.get_rings(parts, return_index=True)
    shell = np.r_[True, ring_of[1:] != ring_of[:-1]]  # get_rings lists each shell before its holes
    turn = shapely.is_ccw(rings) != shell
    rings[turn] = shapely.reverse(rings[turn])
    changed = np.bincount(part_of[ring_of[turn]], minlength=len(geoms)) > 0
    return _single_or_multi(shapely.polygons(rings, indices=ring_of), part_of, len(geoms)), changed


def exact_duplicates(geoms: np.ndarray, ids: Sequence[str]) -> np.ndarray:
    """Per feature: an earlier feature has the same id and the same geometry (ring start and order aside)."""
    present = ~shapely.is_missing(geoms) & ~non_finite(geoms)  # those are dropped for their coordinates
    keys = np.full(len(geoms), None, dtype=object)
    keys[present] = shapely.to_wkb(shapely.normalize(geoms[present]))
    seen: set[tuple[str, bytes]] = set()
    duplicate = np.zeros(len(geoms), dtype=bool)
    for i in np.flatnonzero(present):
        key = (ids[i], keys[i])
        duplicate[i] = key in seen
        seen.add(key)
    return duplicate


def vertex_count(geoms: np.ndarray) -> int:
    """Total vertices (the stats table's measure of simplification)."""
    return int(shapely.get_num_coordinates(geoms[~shapely.is_missing(geoms)]).sum())


@dataclass
class Repaired:
    """Result of repair_polygons: geometries (None where dropped), counts, per-feature drop reason."""

    geoms: np.ndarray
    counts: dict[str, int]
    reasons: np.ndarray


def repair_polygons(geoms: np.ndarray, unclosed: np.ndarray | None = None, min_area: float = 1.0,
                    sliver_thinness: float = 0.05, sliver_width: float = 1.0) -> Repaired:
    """Make every polygon valid, oriented (CCW shells, CW holes), free of repeated vertices and slivers."""
    n = len(geoms)
    reasons = np.full(n, None, dtype=object)
    counts = dict.fromkeys(REPAIR_KINDS, 0)
    counts["unclosed_ring"] = int(np.count_nonzero(unclosed)) if unclosed is not None else 0
    g = geoms.copy()
    reasons[shapely.is_missing(g) | shapely.is_empty(g)] = "no_geometry"
    reasons[(reasons == None) & non_finite(g)] = "non_finite"  # noqa: E711 (numpy)
    wrong = (reasons == None) & ~np.isin(shapely.get_type_id(g), (3, 6))  # noqa: E711 (numpy)
    reasons[wrong] = "wrong_type"
    g[reasons != None] = None  # noqa: E711
    live = np.flatnonzero(reasons == None)  # noqa: E711
    h = g[live]
    counts["orientation"] = int(np.count_nonzero(orient(h)[1]))
    deduped = shapely.remove_repeated_points(h, REPEATED_POINT_TOLERANCE)
    counts["repeated_vertex"] = int(np.count_nonzero(shapely.get_num_coordinates(deduped)
                                                     < shapely.get_num_coordinates(h)))
    invalid = ~shapely.is_valid(deduped)
    counts["invalid"] = int(np.count_nonzero(invalid))
    if invalid.any():
        fixed = polygonal(shapely.make_valid(deduped[invalid], method="structure", keep_collapsed=False))
        counts["multipart"] = int(np.count_nonzero(shapely.get_num_geometries(fixed)
                                                   > shapely.get_num_geometries(deduped[invalid])))
        deduped[invalid] = fixed
    collapsed = shapely.is_missing(deduped)
    reasons[live[collapsed]] = "collapsed"
    live, h = live[~collapsed], deduped[~collapsed]
    parts, index = shapely.get_parts(h, return_index=True)
    area, perimeter = shapely.area(parts), shapely.length(parts)
    small = area < min_area
    with np.errstate(divide="ignore", invalid="ignore"):
        thin = (4 * np.pi * area / perimeter ** 2 < sliver_thinness) & (2 * area / perimeter < sliver_width)
    bad = small | thin
    kept_parts = np.bincount(index[~bad], minlength=len(h))
    counts["sliver_part"] = int(np.count_nonzero((kept_parts > 0) & (np.bincount(index[bad], minlength=len(h)) > 0)))
    all_small = np.bincount(index[small], minlength=len(h)) == np.bincount(index, minlength=len(h))
    gone = kept_parts == 0
    reasons[live[gone]] = np.where(all_small[gone], "too_small", "thin")
    rebuilt = _single_or_multi(parts[~bad], index[~bad], len(h))
    g[:] = None
    g[live] = orient(rebuilt)[0]
    return Repaired(g, counts, reasons)

