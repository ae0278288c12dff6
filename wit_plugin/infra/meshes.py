"""Triangles from the step outputs' faces, shared by the preview renderer and the 3D Tiles export.

* **Planar faces** (LoD1 roofs, holes included) are cut by a constrained Delaunay triangulation
  (``shapely.constrained_delaunay_triangles``, which adds no vertex); values given per ring point
  (z, texture coordinates) are affine in x, y on a planar face, so they are fitted per face on the
  exterior ring and evaluated at the triangles' corners. A self-intersecting face is made valid first.
* **Walls** are fanned from their first vertex (convex quads in LoD1); values per ring point (a generated
  facade's texture coordinates) follow the fan's corners.
* **TIN triangles** are read as they are stored (first three points of each ring).
"""
from __future__ import annotations

import numpy as np
import shapely


def triangle_vertices(geoms: np.ndarray) -> np.ndarray:
    """(n, 3, 3) vertices of triangle polygons; NaN for anything else."""
    xyz = np.full((len(geoms), 3, 3), np.nan)
    ok = ~shapely.is_missing(geoms) & (shapely.get_num_coordinates(geoms) == 4)
    xyz[ok] = shapely.get_coordinates(geoms[ok], include_z=True).reshape(-1, 4, 3)[:, :3]
    return xyz


def planar_triangles(polygons: np.ndarray, ring_values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles of planar faces with ``ring_values`` (one row per exterior-ring point, in the order of
    ``shapely.get_coordinates`` on the exterior rings) fitted affinely per face.

    Returns the triangles' corners in x, y (t, 3, 2), the values there (t, 3, k) and the face of each
    triangle (t,).
    """
    rings = shapely.get_exterior_ring(polygons)
    ring_xy, ring_face = shapely.get_coordinates(rings, return_index=True)
    coef = affine_fit(ring_xy, ring_values, ring_face, len(polygons))
    tris, face = shapely.get_parts(triangulate(shapely.force_2d(polygons)), return_index=True)
    xy = shapely.get_coordinates(tris).reshape(-1, 4, 2)[:, :3]
    fitted = np.einsum("tvk,tpk->tpv", coef[face], np.concatenate([xy, np.ones(xy.shape[:2] + (1,))], axis=2))
    return xy, fitted, face


def triangulate(polygons: np.ndarray) -> np.ndarray:
    """Constrained Delaunay triangles per polygon; an invalid one is made valid first (empty if hopeless)."""
    try:
        return shapely.constrained_delaunay_triangles(polygons)
    except shapely.errors.GEOSException:
        out = np.empty(len(polygons), dtype=object)
        for i, polygon in enumerate(polygons):
            try:
                out[i] = shapely.constrained_delaunay_triangles(polygon)
            except shapely.errors.GEOSException:
                valid = shapely.get_parts(shapely.make_valid(polygon))
                out[i] = shapely.GeometryCollection(list(shapely.get_parts(shapely.constrained_delaunay_triangles(
                    valid[shapely.get_type_id(valid) == 3]))))
        return out


def affine_fit(xy: np.ndarray, values: np.ndarray, owner: np.ndarray, n: int) -> np.ndarray:
    """Per group ``owner``: least-squares a, b, c with value ≈ a·x + b·y + c, shape (n, values, 3)."""
    count = np.maximum(np.bincount(owner, minlength=n), 1)
    mean = np.column_stack([np.bincount(owner, xy[:, k], minlength=n) for k in (0, 1)]) / count[:, None]
    d = xy - mean[owner]
    sums = {(i, j): np.bincount(owner, d[:, i] * d[:, j], minlength=n) for i, j in ((0, 0), (0, 1), (1, 1))}
    normal = np.zeros((n, 2, 2))
    normal[:, 0, 0], normal[:, 0, 1], normal[:, 1, 0], normal[:, 1, 1] = (
        sums[0, 0], sums[0, 1], sums[0, 1], sums[1, 1])
    inverse = np.linalg.pinv(normal)
    coef = np.zeros((n, values.shape[1], 3))
    for v in range(values.shape[1]):
        vmean = np.bincount(owner, values[:, v], minlength=n) / count
        dv = values[:, v] - vmean[owner]
        rhs = np.column_stack([np.bincount(owner, d[:, k] * dv, minlength=n) for k in (0, 1)])
        ab = np.einsum("nij,nj->ni", inverse, rhs)
        coef[:, v, :2] = ab
        coef[:, v, 2] = vmean - (ab * mean).sum(axis=1)
    return coef


def fan_triangles(polygons: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces fanned from the first vertex of their exterior ring: corners (t, 3, 3) and face of each (t,)."""
    xyz, _ = shapely.get_coordinates(shapely.get_exterior_ring(polygons), include_z=True, return_index=True)
    index, owner = fan_corners(polygons)
    return xyz[index], owner


def fan_corners(polygons: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The fans of ``fan_triangles`` as indices (t, 3) into the exterior rings' points (as
    ``shapely.get_coordinates`` lists them, closing points included), so values given per ring point (texture
    coordinates) follow the corners; and the face of each triangle (t,)."""
    counts = shapely.get_num_coordinates(shapely.get_exterior_ring(polygons)) - 1  # without the closing point
    first = np.concatenate([[0], np.cumsum(counts + 1)[:-1]])
    fans = np.maximum(counts - 2, 0)
    owner = np.repeat(np.arange(len(polygons)), fans)
    step = np.arange(len(owner)) - np.repeat(np.cumsum(fans) - fans, fans) + 1
    return np.stack([first[owner], first[owner] + step, first[owner] + step + 1], axis=1), owner
