"""A finished part of the streamed file and the bulk access the checks share.

A part is thousands of elements (see ``citygml.reader``). Its values are pulled out in bulk — one
list of all gml:ids (an XPath), of all posList elements and texts (an lxml ``iter``), of all texture
coordinates … — and checked in numpy: a few Python calls per part and kind instead of several per
element.
"""
from __future__ import annotations

import operator
import re
from itertools import repeat

import numpy as np
from lxml import etree

from ..namespaces import GML_ID
from .names import APP, GML, NAMESPACES, POSITIONS, A, G

NON_NUMBER = re.compile(r"[^0-9eE+\-. \t\r\n]")
BY_ID = etree.XPath("descendant-or-self::*[@gml:id=$v]", namespaces=NAMESPACES)


class Part:
    """The first ``n`` children of ``parent``; ``rest`` is the unfinished child after them."""

    def __init__(self, parent: etree._Element, n: int):
        self.parent, self.n = parent, n
        self.rest = parent[n] if n < len(parent) else None


class Query:
    """An XPath below a part's elements (``path`` follows ``descendant::``), minus the unfinished last child."""

    def __init__(self, *paths: str):
        self._all = etree.XPath(" | ".join(f"descendant::{p}" for p in paths), namespaces=NAMESPACES,
                                smart_strings=False)
        self._count_rest = etree.XPath("count(" + " | ".join(f"descendant-or-self::{p}" for p in paths) + ")",
                                       namespaces=NAMESPACES)

    def __call__(self, part: Part) -> list:
        found = self._all(part.parent)
        if part.rest is not None and found:
            k = int(self._count_rest(part.rest))
            if k:
                del found[len(found) - k:]
        return found


_GEOMETRY = (G["posList"], G["LinearRing"], G["Triangle"])
_APPEARANCE = (A["TexCoordList"], A["textureCoordinates"], A["ring"], A["target"])
_RARE = (G["pos"], G["lowerCorner"], G["upperCorner"], G["Solid"], A["imageURI"])


class Elements:
    """The part's elements of the kinds the checks read, by kind, in file order.

    Each frequent kind is one lxml ``iter`` (the list is built in C); the rare kinds share one.
    The children of a geometry hold no appearance elements and those of an appearance no
    geometry but points (``gml:pos``), so a part below either skips the other's kinds.
    """

    def __init__(self, part: Part):
        parent, rest = part.parent, part.rest
        ns = parent.tag.split("}")[0][1:] if parent is not None and parent.getparent() is not None else ""
        frequent = (() if ns == APP else _GEOMETRY) + (() if ns == GML else _APPEARANCE)
        found: dict[str, list[etree._Element]] = {tag: [] for tag in _GEOMETRY + _APPEARANCE + _RARE}
        for tag in frequent:
            found[tag] = list(parent.iter(tag))
        for node in parent.iter(*_RARE):
            found[node.tag].append(node)
        if parent.tag in found and found[parent.tag] and found[parent.tag][0] is parent:
            found[parent.tag].pop(0)
        if rest is not None:
            for node in rest.iter(*(frequent + _RARE)):
                found[node.tag].pop()
        self.found = found

    def __getitem__(self, tag: str) -> list[etree._Element]:
        return self.found[tag]


def token_counts(texts: list[str]) -> np.ndarray:
    """Whitespace-separated tokens per text: counted as spaces + 1 when all are single-spaced (C speed)."""
    if not texts:
        return np.zeros(0, dtype=np.int64)
    joined = " ".join(texts)
    if "  " in joined or "\n" in joined or "\t" in joined or "\r" in joined or joined[0] == " " or joined[-1] == " ":
        return np.fromiter(map(len, map(str.split, texts)), dtype=np.int64, count=len(texts))
    return np.fromiter(map(str.count, texts, repeat(" ")), dtype=np.int64, count=len(texts)) + 1


def numbers(texts: list[str], expected: int) -> np.ndarray | None:
    """All numbers of ``texts`` as one array, or None when any token is not a number."""
    joined = " ".join(texts)
    if NON_NUMBER.search(joined):
        return None
    values = np.fromstring(joined, sep=" ")
    return values if len(values) == expected else None


def ring_values(ring: etree._Element) -> list[float] | None:
    """The coordinates of a LinearRing (posList or pos), or None when they are not 3D numbers."""
    values: list[float] = []
    for node in ring:
        if node.tag in POSITIONS:
            tokens = (node.text or "").split()
            wrong_count = len(tokens) % 3 if node.tag == G["posList"] else len(tokens) != 3
            if srs_dimension(node) not in (None, 3) or wrong_count:
                return None
            try:
                values += map(float, tokens)
            except ValueError:
                return None
    return values or None


def ring_point_counts(elements: Elements, counts: np.ndarray, exact: bool) -> tuple[list[str], np.ndarray]:
    """Ids of the part's LinearRings that have one, and their number of positions (0 when they are not 3D).

    ``exact``: some srsDimension is not 3, so each ring's own dimension is looked up.
    """
    rings, poslists = elements[G["LinearRing"]], elements[G["posList"]]
    if not rings:
        return [], np.zeros(0, dtype=np.uint32)
    if not exact and len(rings) == len(poslists) and all(map(operator.is_, map(_parent, poslists), rings)):
        ids = [ring.get(GML_ID) for ring in rings]
        keep = [k for k, gid in enumerate(ids) if gid]
        kept = counts[keep]
        return [ids[k] for k in keep], np.where(kept % 3, 0, kept // 3).astype(np.uint32)
    out_ids, out_points = [], []
    for ring in rings:
        gid = ring.get(GML_ID)
        if gid:
            values = ring_values(ring)
            out_ids.append(gid)
            out_points.append(len(values) // 3 if values else 0)
    return out_ids, np.asarray(out_points, dtype=np.uint32)


def _parent(node: etree._Element) -> etree._Element | None:
    return node.getparent()


def line_of(node: etree._Element) -> int:
    return node.sourceline or 0


def srs_dimension(node: etree._Element | None) -> int | None:
    """srsDimension of the position element or its nearest ancestor that declares one."""
    value = inherited(node, "srsDimension")
    if value is None:
        return None
    return int(value) if value.isdigit() else None


def inherited(node: etree._Element | None, attribute: str) -> str | None:
    while node is not None:
        value = node.get(attribute)
        if value is not None:
            return value
        node = node.getparent()
    return None
