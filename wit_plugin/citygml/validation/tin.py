"""TIN triangles: closed rings of 3 corners, and not degenerate (an area above the minimum)."""
from __future__ import annotations

import numpy as np
from lxml import etree

from ..namespaces import GML_ID
from .context import FileContext
from .crs import Frame
from .geometry import triangle_areas
from .names import G
from .parts import Elements, Part, Query, numbers, ring_values, token_counts

_TRIANGLE_TEXTS = Query("gml:Triangle/gml:exterior/gml:LinearRing/gml:posList/text()")


class TriangleChecks:
    """The part's triangles: their posLists in bulk when all are regular, else one by one."""

    def __init__(self, ctx: FileContext, min_triangle_area: float):
        self.ctx, self.issues, self.min_area = ctx, ctx.issues, min_triangle_area

    def check(self, part: Part, elements: Elements, poslists: list[str], counts: np.ndarray) -> None:
        triangles = elements[G["Triangle"]]
        if not triangles:
            return
        n = len(triangles)
        if n == len(elements[G["LinearRing"]]) == len(poslists):  # nothing but triangles: their posLists
            texts, tokens = poslists, counts
        else:
            texts = _TRIANGLE_TEXTS(part)
            tokens = token_counts(texts)
        values = numbers(texts, 12 * n) if len(texts) == n and (tokens == 12).all() else None
        if values is None:
            self._triangles_one_by_one(triangles)
            return
        if self.ctx.own_crs_possible():
            frames = [self.ctx.frame(t) for t in triangles]
        else:
            frames = [self.ctx.frame(part.parent)] * n
        self._check_triangles(values.reshape(-1, 4, 3), frames, triangles)

    def _triangles_one_by_one(self, triangles: list[etree._Element]) -> None:
        corners, frames, checked = [], [], []
        for tri in triangles:
            ring = next((r for e in tri.iterchildren(G["exterior"]) for r in e.iterchildren(G["LinearRing"])), None)
            values = ring_values(ring) if ring is not None else None
            if values is None:
                continue
            if len(values) != 12 or values[:3] != values[9:]:
                self.issues.add("degenerate-triangle", tri.sourceline, _triangle_id(tri), f"Triangle has "
                                f"{len(values) // 3} positions; it needs 4 (3 corners and the first repeated).")
                continue
            corners.append(values)
            frames.append(self.ctx.frame(tri))
            checked.append(tri)
        if corners:
            self._check_triangles(np.asarray(corners).reshape(-1, 4, 3), frames, checked)

    def _check_triangles(self, corners: np.ndarray, frames: list[Frame], triangles: list[etree._Element]) -> None:
        """Closed rings, then an area above ``min_triangle_area`` m²."""
        open_ring = (corners[:, 0] != corners[:, 3]).any(axis=1)
        areas, swapped = triangle_areas(corners[:, :3], frames)
        self.ctx.warn_swapped(swapped)
        bad = open_ring | (areas <= self.min_area)
        if not bad.any():
            return
        for k in np.flatnonzero(bad):
            tri = triangles[k]
            if open_ring[k]:
                self.issues.add("degenerate-triangle", tri.sourceline, _triangle_id(tri), "Triangle has 4 positions "
                                "but the last does not repeat the first; it needs 3 corners and the first repeated.")
            else:
                self.issues.add("degenerate-triangle", tri.sourceline, _triangle_id(tri), f"Triangle is degenerate "
                                f"(area {areas[k]:.3g} m² ≤ {self.min_area:g} m²): its corners coincide or are "
                                "collinear.")


def _triangle_id(tri: etree._Element) -> str | None:
    return tri.get(GML_ID) or next((r.get(GML_ID) for r in tri.iter(G["LinearRing"]) if r.get(GML_ID)), None)
