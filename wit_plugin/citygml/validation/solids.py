"""Solids: every shell's faces gathered (plain polygons in bulk, others face by face) and checked together
(``geometry.SolidCheck``: closed, oriented, planar, simple faces)."""
from __future__ import annotations

import numpy as np
from lxml import etree

from ..namespaces import GML_ID, HREF
from .context import FileContext
from .geometry import SolidBatch, SolidCheck, Where
from .names import NAMESPACES, G, label, owner_id
from .parts import BY_ID, Elements, Part, Query, numbers, ring_values, token_counts

_FACES = "gml:exterior/gml:Shell/gml:surfaceMember/gml:Polygon"
_SHELLS = Query("gml:Solid/gml:exterior/gml:Shell")
_FACE_TEXTS = Query(f"gml:Solid/{_FACES}/gml:exterior/gml:LinearRing/gml:posList/text()")
_HOLES = Query(f"gml:Solid/{_FACES}/gml:interior", "gml:Solid/gml:interior")
_SOLID_FACE_TEXTS = etree.XPath(f"{_FACES}/gml:exterior/gml:LinearRing/gml:posList/text()", namespaces=NAMESPACES,
                                smart_strings=False)
_SOLID_HOLES = etree.XPath(f"count({_FACES}/gml:interior | gml:interior)", namespaces=NAMESPACES)
_FACE_POLYGONS = etree.XPath(_FACES, namespaces=NAMESPACES)


class SolidChecks:
    """The part's solids, checked with the vertex and planarity tolerances (m)."""

    def __init__(self, ctx: FileContext, vertex_tol: float, planarity_tol: float):
        self.ctx, self.issues = ctx, ctx.issues
        self.vertex_tol, self.planarity_tol = vertex_tol, planarity_tol

    def check(self, part: Part, elements: Elements) -> None:
        """Every solid of the part: plain shells of polygons in bulk, others face by face; then checked together.

        A shell is plain when each of its members is a polygon whose exterior ring has a posList, and
        no polygon has a hole: then the part's face texts, in file order, fall to the solids by their
        number of members. When the counts do not add up, each solid is looked at on its own.
        """
        solids = elements[G["Solid"]]
        if not solids:
            return
        shells = _SHELLS(part)
        members = [len(shell) for shell in shells]
        texts = _FACE_TEXTS(part)
        general: list[etree._Element]
        if len(shells) == len(solids) and sum(members) == len(texts) and not _HOLES(part):
            bulk, bulk_faces, general = solids, members, []
        else:
            bulk, texts, bulk_faces, general = [], [], [], []
            for solid in solids:
                face_texts = _SOLID_FACE_TEXTS(solid)
                shell = solid.find(f"{G['exterior']}/{G['Shell']}")
                if face_texts and shell is not None and len(shell) == len(face_texts) and not _SOLID_HOLES(solid):
                    bulk.append(solid)
                    texts += face_texts
                    bulk_faces.append(len(face_texts))
                else:
                    general.append(solid)
        counts = token_counts(texts)
        values = numbers(texts, int(counts.sum())) if texts and not (counts % 3).any() else None
        if values is None:  # some face is not 3D numbers: sort them out solid by solid
            general, bulk, bulk_faces, counts = bulk + general, [], [], counts[:0]
        faced = [(solid, faces) for solid in general for faces in [self._general_faces(solid)] if faces]
        solids = bulk + [solid for solid, _ in faced]
        if not solids:
            return
        faces = [face for _, solid_faces in faced for face in solid_faces]
        rings = [ring for _, face_rings in faces for ring in face_rings]
        rings_per_face = np.r_[np.ones(sum(bulk_faces), dtype=np.int64), [len(r) for _, r in faces]].astype(np.int64)
        if self.ctx.own_crs_possible():
            frames = [self.ctx.frame(solid) for solid in solids]
        else:
            frames = [self.ctx.frame(part.parent)] * len(solids)
        batch = SolidBatch(
            solids=[Where(solid.sourceline, solid.get(GML_ID), label(solid)) for solid in solids],
            frames=frames,
            points=np.concatenate(([values.reshape(-1, 3)] if bulk and values is not None else []) + rings),
            ring_len=np.r_[counts // 3, [len(r) for r in rings]].astype(np.int64),
            ring_face=np.repeat(np.arange(len(rings_per_face)), rings_per_face),
            face_solid=np.repeat(np.arange(len(solids)), bulk_faces + [len(f) for _, f in faced]),
            face_where=_FaceLookup(bulk, bulk_faces, [where for where, _ in faces]))
        check = SolidCheck(batch, self.issues, self.vertex_tol, self.planarity_tol)
        check.run()
        self.ctx.warn_swapped(check.swapped)

    def _general_faces(self, solid: etree._Element) -> list[tuple[Where, list[np.ndarray]]]:
        """(face, rings) of any shell: orientable, composite, referenced surfaces; [] when it cannot be checked."""
        faces: list = []
        try:
            for shell in solid.iterfind(f"{G['exterior']}/{G['Shell']}"):
                self._collect_faces(shell, False, _feature_of(solid), faces)
        except _Unresolved as exc:
            self.issues.add("solid-closed", solid.sourceline, solid.get(GML_ID), f"Solid not checked: its surface "
                            f"#{exc} is not defined in the same feature.", "warning")
            return []
        except _Unparsed:
            return []  # coordinates that are not numbers: the XSD check reports it
        return faces

    def _collect_faces(self, node: etree._Element, reverse: bool, feature: etree._Element, out: list) -> None:
        """Polygons of a shell/composite/orientable surface as (where, [rings]), in shell orientation."""
        for child in node:
            if child.tag not in (G["surfaceMember"], G["baseSurface"], G["patches"]):
                continue
            targets = list(child)
            href = child.get(HREF)
            if not targets and href and href.startswith("#"):
                found = BY_ID(feature, v=href[1:])
                if not found:
                    raise _Unresolved(href[1:])
                targets = found[:1]
            for surface in targets:
                if surface.tag in (G["Polygon"], G["PolygonPatch"]):
                    ring_nodes = [r for side in surface for r in side if r.tag == G["LinearRing"]
                                  and side.tag in (G["exterior"], G["interior"])]
                    coords = [ring_values(r) for r in ring_nodes]
                    if not ring_nodes or any(c is None or len(c) % 3 for c in coords):
                        raise _Unparsed()
                    arrays = [np.asarray(c).reshape(-1, 3) for c in coords]
                    out.append((Where(surface.sourceline, owner_id(surface), label(surface)),
                                [a[::-1] for a in arrays] if reverse else arrays))
                elif surface.tag == G["OrientableSurface"]:
                    self._collect_faces(surface, reverse ^ (surface.get("orientation") == "-"), feature, out)
                elif surface.tag in (G["CompositeSurface"], G["Surface"], G["MultiSurface"], G["Shell"]):
                    self._collect_faces(surface, reverse, feature, out)


class _FaceLookup:
    """Face number → ``Where``: faces of the bulk solids are found again in their solid (only for messages)."""

    def __init__(self, solids: list[etree._Element], faces_per_solid: list[int], listed: list[Where]):
        self.solids, self.listed = solids, listed
        self.starts = np.r_[0, np.cumsum(faces_per_solid)].astype(np.int64)

    def __call__(self, face: int) -> Where:
        bulk = int(self.starts[-1])
        if face >= bulk:
            return self.listed[face - bulk]
        s = int(np.searchsorted(self.starts, face, side="right")) - 1
        polygon = _FACE_POLYGONS(self.solids[s])[face - int(self.starts[s])]
        return Where(polygon.sourceline, owner_id(polygon), label(polygon))


class _Unresolved(Exception):
    """A shell member refers to a surface outside the feature being checked."""


class _Unparsed(Exception):
    """A face's coordinates are missing or not 3D numbers (reported by the XSD/dimension checks)."""


def _feature_of(node: etree._Element) -> etree._Element:
    """The top-level member (child of the root) that holds ``node``."""
    while node.getparent() is not None and node.getparent().getparent() is not None:
        node = node.getparent()
    return node
