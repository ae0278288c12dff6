"""Every position 3D (x y z): posList, pos and envelope corners."""
from __future__ import annotations

import numpy as np
from lxml import etree

from .context import FileContext
from .names import G, owner_id, qname
from .parts import Elements, Part, inherited, line_of, srs_dimension, token_counts


class PositionChecks:
    """The dimension of every position: in bulk, or element by element in a part with any exception."""

    def __init__(self, ctx: FileContext):
        self.ctx, self.issues = ctx, ctx.issues

    def check(self, part: Part, elements: Elements, counts: np.ndarray) -> None:
        """All positions 3D: checked in bulk; a part with any exception is checked element by element."""
        points = [node for tag in (G["pos"], G["lowerCorner"], G["upperCorner"]) for node in elements[tag]]
        regular = (not (counts % 3).any() and not self.ctx.raw.any_dimension_not_3
                   and (token_counts([node.text or "" for node in points]) == 3).all())
        if regular:
            return
        for node in sorted(elements[G["posList"]] + points, key=line_of):
            self._check_dimension(node, len((node.text or "").split()))

    def _check_dimension(self, node: etree._Element, count: int) -> bool:
        """True when the position element holds 3D positions; reports it otherwise.

        A geometry in its own CRS (e.g. an address point in EPSG:4326, as in the official
        examples) gets a warning: its dimension follows that CRS, which cannot be looked up offline.
        """
        dim = srs_dimension(node)
        if dim is not None and dim != 3:
            problem = f"{qname(node.tag)} has srsDimension=\"{dim}\": coordinates must be 3D (x y z)."
        elif node.tag == G["posList"] and count % 3:
            problem = f"gml:posList has {count} numbers, not a multiple of 3: every position must be 3D (x y z)."
        elif node.tag != G["posList"] and count != 3:
            problem = f"{qname(node.tag)} has {count} numbers: a position must be 3D (x y z)."
        else:
            return True
        own_crs = inherited(node, "srsName")
        if dim is None and own_crs and own_crs != self.ctx.model_crs and count % 2 == 0:
            self.issues.add("dimension", node.sourceline, owner_id(node), f"{problem[:-1]}, unless its own CRS "
                            f"{own_crs} is 2D; city-object geometry should be 3D in the model's CRS.", "warning")
        else:
            self.issues.add("dimension", node.sourceline, owner_id(node), problem)
        return False
