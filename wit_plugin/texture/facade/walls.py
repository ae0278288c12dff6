"""Texture coordinates of LoD1 walls on a facade image: u along the footprint ring, v in storeys.

Walls come as the extrusion writes them: one quad per footprint edge, ring (p, q at the base; q, p at the
top; p again), the edges of each ring in order (exterior, then each courtyard). ``u`` counts modules along
the ring from the building's phase: ``u = phase + s · k / P`` for a point ``s`` metres along a ring of
perimeter ``P`` holding ``k = round(P / MODULE_WIDTH)`` modules (at least one), so u runs on without a jump
at every corner and closes on a whole number of modules (the texture wraps: no seam where the ring starts).
``v`` is 0 at the wall's foot and ``storeys / rows`` at its top: one image row per storey, the roof line on
a row boundary.
"""
from __future__ import annotations

import numpy as np

from .modules import MODULE_WIDTH

QUAD_POINTS = 5  # a wall quad's ring, closing point included
_SAME_POINT = 1e-6  # m: an edge's start meets the previous edge's end (coordinates are copied, not recomputed)


def wall_texcoords(base: np.ndarray, first: np.ndarray, phase: np.ndarray, top_v: np.ndarray) -> np.ndarray:
    """(u, v) of every point of ``len(base)`` wall quads, as (walls · QUAD_POINTS, 2).

    ``base`` (walls, 2, 2): each wall's base edge p → q in x, y, the walls of a building in ring order;
    ``first`` (walls,) True where a building's walls start; ``phase`` and ``top_v`` per wall (their building's).
    A ring ends where the next wall does not start at this wall's end (or a building starts).
    """
    p, q = base[:, 0], base[:, 1]
    length = np.hypot(*(q - p).T)
    starts = first.copy()
    starts[1:] |= np.abs(p[1:] - q[:-1]).max(axis=1) > _SAME_POINT
    starts[0] = True
    ring = np.cumsum(starts) - 1
    perimeter = np.bincount(ring, weights=length)
    modules = np.maximum(1.0, np.round(perimeter / MODULE_WIDTH))
    scale = np.divide(modules, perimeter, out=np.zeros_like(perimeter), where=perimeter > 0)[ring]
    run = np.cumsum(length)
    before = run - length  # metres from the first wall of the building batch to this wall's start
    ring_start = before[starts][ring]
    u0 = phase + (before - ring_start) * scale
    u1 = phase + (run - ring_start) * scale
    v1 = top_v
    zero = np.zeros_like(u0)
    uv = np.stack([np.column_stack(pair) for pair in ((u0, zero), (u1, zero), (u1, v1), (u0, v1), (u0, zero))],
                  axis=1)
    return uv.reshape(-1, 2)
