"""Every check an XSD cannot express, on the finished parts of one streaming parse.

A part is thousands of elements (see ``stream``). Its values are pulled out in bulk — one list of
all gml:ids (an XPath), of all posList elements and texts (an lxml ``iter``), of all texture
coordinates … — and checked in numpy: a few Python calls per part and kind instead of several per
element. Elements are looked at one by one only to name a problem (its line, its gml:id) or when a
part does not have the regular layout the bulk path relies on (a ring without a posList, a face
that is an OrientableSurface, …); that general path checks the same rules element by element
(``tests/test_validate.py`` runs both on every fixture).
"""
from __future__ import annotations

import math
import operator
import re
from array import array
from itertools import repeat
from pathlib import Path
from typing import NamedTuple

import numpy as np
from lxml import etree

from ..namespaces import GML_ID, HREF
from ..reader import RawCounts
from .crs import Frame, frame_of, metre_axes
from .geometry import SolidBatch, SolidCheck, Where, triangle_areas
from .ids import IdStore, hashes
from .names import (
    APP,
    GML,
    NAMESPACES,
    POSITIONS,
    A,
    G,
    IssueList,
    label,
    owner_id,
    qname,
    remove_keep_tail,
)

_NON_NUMBER = re.compile(r"[^0-9eE+\-. \t\r\n]")
_REMOTE = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]+://")


class _Part:
    """The first ``n`` children of ``parent``; ``rest`` is the unfinished child after them."""

    def __init__(self, parent: etree._Element, n: int):
        self.parent, self.n = parent, n
        self.rest = parent[n] if n < len(parent) else None


class _Query:
    """An XPath below a part's elements (``path`` follows ``descendant::``), minus the unfinished last child."""

    def __init__(self, *paths: str):
        self._all = etree.XPath(" | ".join(f"descendant::{p}" for p in paths), namespaces=NAMESPACES,
                                smart_strings=False)
        self._count_rest = etree.XPath("count(" + " | ".join(f"descendant-or-self::{p}" for p in paths) + ")",
                                       namespaces=NAMESPACES)

    def __call__(self, part: _Part) -> list:
        found = self._all(part.parent)
        if part.rest is not None and found:
            k = int(self._count_rest(part.rest))
            if k:
                del found[len(found) - k:]
        return found


_GEOMETRY = (G["posList"], G["LinearRing"], G["Triangle"])
_APPEARANCE = (A["TexCoordList"], A["textureCoordinates"], A["ring"], A["target"])
_RARE = (G["pos"], G["lowerCorner"], G["upperCorner"], G["Solid"], A["imageURI"])


class _Elements:
    """The part's elements of the kinds the checks read, by kind, in file order.

    Each frequent kind is one lxml ``iter`` (the list is built in C); the rare kinds share one.
    The children of a geometry hold no appearance elements and those of an appearance no
    geometry but points (``gml:pos``), so a part below either skips the other's kinds.
    """

    def __init__(self, part: _Part):
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


_IDS = _Query("*/@gml:id")
_HREFS = _Query("*/@xlink:href")
_TRIANGLE_TEXTS = _Query("gml:Triangle/gml:exterior/gml:LinearRing/gml:posList/text()")
_UNEVEN_LISTS = _Query("app:TexCoordList[count(app:textureCoordinates) != count(app:ring)]")
_WITH_HREF = _Query("*[@xlink:href]")
_FACES = "gml:exterior/gml:Shell/gml:surfaceMember/gml:Polygon"
_SHELLS = _Query("gml:Solid/gml:exterior/gml:Shell")
_FACE_TEXTS = _Query(f"gml:Solid/{_FACES}/gml:exterior/gml:LinearRing/gml:posList/text()")
_HOLES = _Query(f"gml:Solid/{_FACES}/gml:interior", "gml:Solid/gml:interior")
_SOLID_FACE_TEXTS = etree.XPath(f"{_FACES}/gml:exterior/gml:LinearRing/gml:posList/text()", namespaces=NAMESPACES,
                                smart_strings=False)
_SOLID_HOLES = etree.XPath(f"count({_FACES}/gml:interior | gml:interior)", namespaces=NAMESPACES)
_FACE_POLYGONS = etree.XPath(_FACES, namespaces=NAMESPACES)
_BY_ID = etree.XPath("descendant-or-self::*[@gml:id=$v]", namespaces=NAMESPACES)


class FileCheck:
    """All checks of one file, fed part by part (``part``), concluded by ``finish``."""

    def __init__(self, path: Path, issues: IssueList, raw: RawCounts, planarity_tol: float, vertex_tol: float,
                 min_triangle_area: float):
        self.path, self.issues, self.raw = path, issues, raw
        self.planarity_tol, self.vertex_tol, self.min_area = planarity_tol, vertex_tol, min_triangle_area
        self.ids = IdStore()
        self.forward_refs: dict[str, tuple[int | None, str]] = {}  # to ids not seen yet: resolved at the end
        self.tex_rings: list[tuple[str, int, int | None, str | None]] = []  # ring id, pairs, line, texture
        self.forward_tex_rings: list[tuple[str, int, int | None, str | None]] = []
        self.tex_lists: dict[etree._Element, _TexCoordPairs] = {}  # lists handed out in several parts
        self.images: set[str] = set()
        self.entities_possible = False
        self.root: etree._Element | None = None
        self.model_crs: str | None = None
        self.inline_metres: dict[str, bool] = {}  # CRSs defined in the file: all axes in metres?
        self.warned: set = set()  # CRS names (and ("swapped", name)) already warned about

    # -- document ------------------------------------------------------------------------------
    def start(self, root: etree._Element) -> None:
        self.root = root
        docinfo = root.getroottree().docinfo
        if docinfo.internalDTD is not None or docinfo.doctype:
            self.entities_possible = True
            self.issues.add("xml", 1, None, "The file has a DOCTYPE. CityGML needs none; its entity declarations "
                            "are ignored (never expanded or fetched, for security).", "warning")
        gid = root.get(GML_ID)
        if gid:
            self.ids.add(hashes([gid]), np.zeros(1))

    def finish(self) -> None:
        forward = self.forward_refs
        found = self.ids.find(hashes(list(forward)))[0]
        for (ref, (line, how)), ok in zip(forward.items(), found.tolist()):
            if not ok:
                self.issues.add("reference", line, None, f"{how} '#{ref}' points to no gml:id in this file.")
        self._compare_tex(self.forward_tex_rings, None)

    # -- parts ---------------------------------------------------------------------------------
    def part(self, parent: etree._Element, n: int) -> None:
        part = _Part(parent, n)
        if parent is self.root:
            self._model_properties(parent, n)
        if self.entities_possible:
            self._entities(parent, n)
        elements = _Elements(part)
        poslists = [node.text or "" for node in elements[G["posList"]]]
        counts = _token_counts(poslists)
        self._add_ids(part, elements, counts)
        self._dimensions(part, elements, counts)
        self._triangles(part, elements, poslists, counts)
        self._solids(part, elements)
        rings = self._references(part, elements)
        self._textures(part, elements, rings)

    def _model_properties(self, root: etree._Element, n: int) -> None:
        """The model's CRS (its envelope) and the CRSs it defines inline (``srsName="#id"``)."""
        for child in root[:n]:
            if not isinstance(child.tag, str):
                continue  # an entity reference between members
            if self.model_crs is None and child.tag == G["boundedBy"]:
                envelope = child.find(G["Envelope"])
                self.model_crs = envelope.get("srsName") if envelope is not None else None
            if child.tag.endswith("CRS"):  # core:engineeringCRS
                for crs in child.iter():
                    if crs.get(GML_ID) and isinstance(crs.tag, str) and crs.tag.endswith("CRS"):
                        uoms = [axis.get("uom", "") for axis in crs.iter(G["CoordinateSystemAxis"])]
                        self.inline_metres[crs.get(GML_ID)] = metre_axes(uoms)

    def _entities(self, parent: etree._Element, n: int) -> None:
        for child in parent[:n]:
            for ent in list(child.iter(etree.Entity)):
                self.issues.add("xml", ent.getparent().sourceline, None, f"Uses the XML entity {ent.text}: entities "
                                "are not expanded (security), so its content is missing. Write the text directly.")
                remove_keep_tail(ent)

    # -- ids -----------------------------------------------------------------------------------
    def _add_ids(self, part: _Part, elements: _Elements, counts: np.ndarray) -> None:
        """Store every gml:id with its ring's point count; report the ids used before."""
        ids = _IDS(part)
        if not ids:
            return
        keys = hashes(ids)
        points = np.zeros(len(ids), dtype=np.uint32)
        ring_ids, ring_points = _ring_points(elements, counts, exact=self.raw.any_dimension_not_3)
        if ring_ids:
            ring_keys = hashes(ring_ids)
            order = np.argsort(ring_keys)
            at = np.minimum(np.searchsorted(ring_keys[order], keys), len(order) - 1)
            hit = ring_keys[order][at] == keys
            points[hit] = ring_points[order][at[hit]]
        duplicate = self.ids.add(keys, points)
        if duplicate.any():
            self._report_duplicates(part, [ids[i] for i in np.flatnonzero(duplicate)])

    def _report_duplicates(self, part: _Part, duplicates: list[str]) -> None:
        """Name each later occurrence (its line) of an id met before."""
        extra: dict[str, int] = {}
        for gid in duplicates:
            extra[gid] = extra.get(gid, 0) + 1
        found = []
        for gid, k in extra.items():
            nodes = [node for child in part.parent[:part.n] for node in _BY_ID(child, v=gid)]
            found += [(node.sourceline or 0, gid) for node in nodes[len(nodes) - k:]]
        for line, gid in sorted(found):
            self.issues.add("duplicate-id", line or None, gid, f"gml:id '{gid}' is used more than once; every gml:id "
                            "in a file must be unique.")

    # -- positions -----------------------------------------------------------------------------
    def _dimensions(self, part: _Part, elements: _Elements, counts: np.ndarray) -> None:
        """All positions 3D: checked in bulk; a part with any exception is checked element by element."""
        points = [node for tag in (G["pos"], G["lowerCorner"], G["upperCorner"]) for node in elements[tag]]
        regular = (not (counts % 3).any() and not self.raw.any_dimension_not_3
                   and (_token_counts([node.text or "" for node in points]) == 3).all())
        if regular:
            return
        for node in sorted(elements[G["posList"]] + points, key=_line):
            self._check_dimension(node, len((node.text or "").split()))

    def _check_dimension(self, node: etree._Element, count: int) -> bool:
        """True when the position element holds 3D positions; reports it otherwise.

        A geometry in its own CRS (e.g. an address point in EPSG:4326, as in the official
        examples) gets a warning: its dimension follows that CRS, which cannot be looked up offline.
        """
        dim = _srs_dimension(node)
        if dim is not None and dim != 3:
            problem = f"{qname(node.tag)} has srsDimension=\"{dim}\": coordinates must be 3D (x y z)."
        elif node.tag == G["posList"] and count % 3:
            problem = f"gml:posList has {count} numbers, not a multiple of 3: every position must be 3D (x y z)."
        elif node.tag != G["posList"] and count != 3:
            problem = f"{qname(node.tag)} has {count} numbers: a position must be 3D (x y z)."
        else:
            return True
        own_crs = _inherited(node, "srsName")
        if dim is None and own_crs and own_crs != self.model_crs and count % 2 == 0:
            self.issues.add("dimension", node.sourceline, owner_id(node), f"{problem[:-1]}, unless its own CRS "
                            f"{own_crs} is 2D; city-object geometry should be 3D in the model's CRS.", "warning")
        else:
            self.issues.add("dimension", node.sourceline, owner_id(node), problem)
        return False

    def _frame(self, node: etree._Element) -> Frame:
        """The CRS frame of a geometry: its own or inherited srsName, else the model's; unknown ones warned once."""
        name = _inherited(node, "srsName") or self.model_crs
        frame = frame_of(name, self.inline_metres)
        if frame.assumed and name not in self.warned:
            self.warned.add(name)
            self.issues.add("crs", None, None, f"{'CRS ' + repr(name) if name else 'CRS'}: {frame.assumed}; the "
                            "geometric tolerances take the coordinates as metres.", "warning")
        return frame

    def _warn_swapped(self, frames: list[Frame]) -> None:
        for frame in frames:
            if ("swapped", frame.name) not in self.warned:
                self.warned.add(("swapped", frame.name))
                self.issues.add("crs", None, None, f"Coordinates in {frame.name} give longitude before latitude "
                                "(a latitude beyond ±90° otherwise), unlike the CRS's axis order; read as "
                                "longitude/latitude.", "warning")

    # -- TIN triangles -------------------------------------------------------------------------
    def _triangles(self, part: _Part, elements: _Elements, poslists: list[str], counts: np.ndarray) -> None:
        triangles = elements[G["Triangle"]]
        if not triangles:
            return
        n = len(triangles)
        if n == len(elements[G["LinearRing"]]) == len(poslists):  # nothing but triangles: their posLists
            texts, tokens = poslists, counts
        else:
            texts = _TRIANGLE_TEXTS(part)
            tokens = _token_counts(texts)
        values = _numbers(texts, 12 * n) if len(texts) == n and (tokens == 12).all() else None
        if values is None:
            self._triangles_one_by_one(triangles)
            return
        if self._own_crs_possible():
            frames = [self._frame(t) for t in triangles]
        else:
            frames = [self._frame(part.parent)] * n
        self._check_triangles(values.reshape(-1, 4, 3), frames, triangles)

    def _triangles_one_by_one(self, triangles: list[etree._Element]) -> None:
        corners, frames, checked = [], [], []
        for tri in triangles:
            ring = next((r for e in tri.iterchildren(G["exterior"]) for r in e.iterchildren(G["LinearRing"])), None)
            values = _ring_values(ring) if ring is not None else None
            if values is None:
                continue
            if len(values) != 12 or values[:3] != values[9:]:
                self.issues.add("degenerate-triangle", tri.sourceline, _triangle_id(tri), f"Triangle has "
                                f"{len(values) // 3} positions; it needs 4 (3 corners and the first repeated).")
                continue
            corners.append(values)
            frames.append(self._frame(tri))
            checked.append(tri)
        if corners:
            self._check_triangles(np.asarray(corners).reshape(-1, 4, 3), frames, checked)

    def _check_triangles(self, corners: np.ndarray, frames: list[Frame], triangles: list[etree._Element]) -> None:
        """Closed rings, then an area above ``min_triangle_area`` m²."""
        open_ring = (corners[:, 0] != corners[:, 3]).any(axis=1)
        areas, swapped = triangle_areas(corners[:, :3], frames)
        self._warn_swapped(swapped)
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

    # -- solids --------------------------------------------------------------------------------
    def _solids(self, part: _Part, elements: _Elements) -> None:
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
        counts = _token_counts(texts)
        values = _numbers(texts, int(counts.sum())) if texts and not (counts % 3).any() else None
        if values is None:  # some face is not 3D numbers: sort them out solid by solid
            general, bulk, bulk_faces, counts = bulk + general, [], [], counts[:0]
        faced = [(solid, faces) for solid in general for faces in [self._general_faces(solid)] if faces]
        solids = bulk + [solid for solid, _ in faced]
        if not solids:
            return
        faces = [face for _, solid_faces in faced for face in solid_faces]
        rings = [ring for _, face_rings in faces for ring in face_rings]
        rings_per_face = np.r_[np.ones(sum(bulk_faces), dtype=np.int64), [len(r) for _, r in faces]].astype(np.int64)
        if self._own_crs_possible():
            frames = [self._frame(solid) for solid in solids]
        else:
            frames = [self._frame(part.parent)] * len(solids)
        batch = SolidBatch(
            solids=[Where(solid.sourceline, solid.get(GML_ID), label(solid)) for solid in solids],
            frames=frames,
            points=np.concatenate(([values.reshape(-1, 3)] if bulk else []) + rings),
            ring_len=np.r_[counts // 3, [len(r) for r in rings]].astype(np.int64),
            ring_face=np.repeat(np.arange(len(rings_per_face)), rings_per_face),
            face_solid=np.repeat(np.arange(len(solids)), bulk_faces + [len(f) for _, f in faced]),
            face_where=_FaceLookup(bulk, bulk_faces, [where for where, _ in faces]))
        check = SolidCheck(batch, self.issues, self.vertex_tol, self.planarity_tol)
        check.run()
        self._warn_swapped(check.swapped)

    def _own_crs_possible(self) -> bool:
        """Whether some geometry may carry its own srsName (an srsName in the bytes read besides the model's)."""
        return self.raw.srs_names > (self.model_crs is not None)

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
                found = _BY_ID(feature, v=href[1:])
                if not found:
                    raise _Unresolved(href[1:])
                targets = found[:1]
            for surface in targets:
                if surface.tag in (G["Polygon"], G["PolygonPatch"]):
                    ring_nodes = [r for side in surface for r in side if r.tag == G["LinearRing"]
                                  and side.tag in (G["exterior"], G["interior"])]
                    coords = [_ring_values(r) for r in ring_nodes]
                    if not ring_nodes or any(c is None or len(c) % 3 for c in coords):
                        raise _Unparsed()
                    arrays = [np.asarray(c).reshape(-1, 3) for c in coords]
                    out.append((Where(surface.sourceline, owner_id(surface), label(surface)),
                                [a[::-1] for a in arrays] if reverse else arrays))
                elif surface.tag == G["OrientableSurface"]:
                    self._collect_faces(surface, reverse ^ (surface.get("orientation") == "-"), feature, out)
                elif surface.tag in (G["CompositeSurface"], G["Surface"], G["MultiSurface"], G["Shell"]):
                    self._collect_faces(surface, reverse, feature, out)

    # -- textures ------------------------------------------------------------------------------
    def _textures(self, part: _Part, elements: _Elements, rings: _RingRefs) -> None:
        for node in elements[A["imageURI"]]:
            uri = (node.text or "").strip()
            if uri in self.images:
                continue
            self.images.add(uri)
            if _REMOTE.match(uri):
                self.issues.add("texture-image", node.sourceline, owner_id(node), f"Texture image {uri} is remote and "
                                "was not checked.", "warning")
            elif not uri or not (self.path.parent / uri).is_file():
                self.issues.add("texture-image", node.sourceline, owner_id(node), f"Texture image '{uri}' does not "
                                f"exist (looked for {self.path.parent / uri}).")
        if part.parent.tag == A["TexCoordList"]:  # a long list handed out in parts
            pairs = self.tex_lists.get(part.parent)
            if pairs is None:
                pairs = self.tex_lists[part.parent] = _TexCoordPairs(self, part.parent)
            pairs.add(elements[A["textureCoordinates"]], elements[A["ring"]])
        elif elements[A["TexCoordList"]]:
            self._texcoord_lists(part, elements, rings)
        self._compare_tex(self.tex_rings, self.forward_tex_rings)
        self.tex_rings = []

    def _texcoord_lists(self, part: _Part, elements: _Elements, refs: _RingRefs) -> None:
        """Pair the k-th coordinates with the k-th ring of all lists at once when each list pairs up evenly."""
        lists, coords, rings = elements[A["TexCoordList"]], elements[A["textureCoordinates"]], elements[A["ring"]]
        if self.tex_lists and any(tcl in self.tex_lists for tcl in lists):  # the end of lists handed out in parts
            for tcl in lists:
                pairs = self.tex_lists.pop(tcl, None)
                if pairs is not None:
                    pairs.add([c for c in tcl if c.tag == A["textureCoordinates"]], [c for c in tcl if c.tag == A["ring"]])
                    pairs.close()
                    del tcl[:]
            coords = [node for node in coords if node.getparent() is not None]
            kept = np.fromiter((node.getparent() is not None for node in rings), dtype=bool, count=len(rings))
            rings, refs = [r for r, k in zip(rings, kept) if k], refs.subset(kept)
        texts = [node.text or "" for node in coords]
        if len(coords) != len(rings) or _UNEVEN_LISTS(part) or _NON_NUMBER.search(" ".join(texts)):
            for tcl in lists:
                pairs = _TexCoordPairs(self, tcl)
                pairs.add([c for c in tcl if c.tag == A["textureCoordinates"]], [c for c in tcl if c.tag == A["ring"]])
                pairs.close()
            return
        counts = _token_counts(texts)
        ring_ids, found, points = refs.ids, refs.found, refs.points
        for k in np.flatnonzero(counts % 2):
            self.issues.add("texture-coordinates", coords[k].sourceline, owner_id(coords[k]), f"Texture coordinates for "
                            f"ring #{ring_ids[k]} have an odd number of values ({counts[k]}); they are (s t) pairs.")
        even = counts % 2 == 0
        pairs = counts // 2
        for k in np.flatnonzero(even & found & (points > 0) & (pairs != points)):
            self._wrong_pairs(ring_ids[k], int(pairs[k]), int(points[k]), coords[k].sourceline, owner_id(coords[k]))
        self.forward_tex_rings += [(ring_ids[k], int(pairs[k]), coords[k].sourceline, owner_id(coords[k]))
                                   for k in np.flatnonzero(even & ~found)]

    def _compare_tex(self, tex_rings: list, unknown: list | None) -> None:
        """Compare texture pairs with the points of the rings seen; put the others in ``unknown`` (None: ignore)."""
        if not tex_rings:
            return
        found, points = self.ids.find(hashes([r[0] for r in tex_rings]))
        for (ring_id, pairs, line, tex_id), ok, n in zip(tex_rings, found.tolist(), points.tolist()):
            if not ok:
                if unknown is not None:
                    unknown.append((ring_id, pairs, line, tex_id))
            elif n and pairs != n:
                self._wrong_pairs(ring_id, pairs, n, line, tex_id)

    def _wrong_pairs(self, ring_id: str, pairs: int, points: int, line: int | None, tex_id: str | None) -> None:
        self.issues.add("texture-coordinates", line, tex_id, f"{pairs} texture coordinate pairs for ring #{ring_id}, "
                        f"which has {points} points; there must be one pair per point (closing point included).")

    # -- references ----------------------------------------------------------------------------
    def _references(self, part: _Part, elements: _Elements) -> _RingRefs:
        """``#id`` references resolved against the ids seen so far; the others wait, with their line, for the end.

        Returns the part's app:ring references looked up, for the texture check.
        """
        hrefs = [h[1:] for h in _HREFS(part) if h.startswith("#")] if self.raw.hrefs else []
        targets = [(node.text or "").strip() for node in elements[A["target"]]]
        rings = [(node.text or "").strip() for node in elements[A["ring"]]]
        target_refs = [t[1:] for t in targets if t.startswith("#")]
        ring_refs = [t[1:] for t in rings if t.startswith("#")]
        refs = hrefs + target_refs + ring_refs
        found, points = self.ids.find(hashes(refs))
        ring_ids = [t.lstrip("#") for t in rings]
        if len(ring_refs) == len(rings):
            ring_lookup = _RingRefs(ring_ids, found[len(refs) - len(rings):], points[len(refs) - len(rings):])
        else:
            ring_lookup = _RingRefs(ring_ids, *self.ids.find(hashes(ring_ids)))
        if found.all():
            return ring_lookup
        missing = {refs[i] for i in np.flatnonzero(~found)}
        located = [(node.sourceline or 0, node.get(HREF)[1:], f"xlink:href of {qname(node.tag)}")
                   for node in (_WITH_HREF(part) if hrefs else []) if node.get(HREF).startswith("#")]
        located += [(node.sourceline or 0, text[1:], qname(node.tag)) for kind, texts in
                    ((A["target"], targets), (A["ring"], rings)) for node, text in zip(elements[kind], texts)
                    if text.startswith("#")]
        for line, ref, how in sorted(located, key=lambda item: item[0]):
            if ref in missing:
                self.forward_refs.setdefault(ref, (line or None, how))
        return ring_lookup


class _RingRefs(NamedTuple):
    """The app:ring references of a part (without '#') and whether and with how many points each ring exists."""
    ids: list[str]
    found: np.ndarray
    points: np.ndarray

    def subset(self, keep: np.ndarray) -> _RingRefs:
        return _RingRefs([r for r, k in zip(self.ids, keep) if k], self.found[keep], self.points[keep])


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


class _TexCoordPairs:
    """Pairs the textureCoordinates of one TexCoordList with its rings, in order, as they come.

    All coordinates come before the rings, so a list handed out in parts keeps only the number of
    pairs and the line of each coordinate list (16 bytes) until its ring arrives, not the elements.
    """

    def __init__(self, fc: FileCheck, tcl: etree._Element):
        self.fc, self.line, self.tex_id = fc, tcl.sourceline, owner_id(tcl)
        self.pairs = array("q")  # (s t) pairs per coordinate list; minus the number of values when it is odd
        self.lines = array("q")
        self.faults: dict[int, list[str]] = {}  # coordinate list -> its non-finite values (first three)
        self.n_rings = 0

    def add(self, coords: list[etree._Element], rings: list[etree._Element]) -> None:
        """The next coordinate lists and ring references of the list (coordinates first, as the schema orders them)."""
        texts = [node.text or "" for node in coords]
        if _NON_NUMBER.search(" ".join(texts)):
            for k, text in enumerate(texts):
                bad = _non_finite(text.split()) if _NON_NUMBER.search(text) else []
                if bad:
                    self.faults[len(self.pairs) + k] = bad[:3]
        counts = _token_counts(texts)
        self.pairs.extend(np.where(counts % 2, -counts, counts // 2).tolist())
        self.lines.extend([node.sourceline or 0 for node in coords])
        first, self.n_rings = self.n_rings, self.n_rings + len(rings)
        ring_ids = [(node.text or "").strip().lstrip("#") for node in rings[:max(0, len(self.pairs) - first)]]
        issues = self.fc.issues
        for k, ring_id in zip(range(first, first + len(ring_ids)), ring_ids):
            pairs, line = self.pairs[k], self.lines[k] or None
            bad = self.faults.pop(k, None) if self.faults else None
            if bad:
                issues.add("texture-coordinates", line, self.tex_id, f"Texture coordinates for ring #{ring_id} "
                           f"contain {', '.join(repr(b) for b in bad)}: each must be a finite number.")
            if pairs < 0:
                issues.add("texture-coordinates", line, self.tex_id, f"Texture coordinates for ring #{ring_id} have "
                           f"an odd number of values ({-pairs}); they are (s t) pairs.")
            else:
                self.fc.tex_rings.append((ring_id, pairs, line, self.tex_id))

    def close(self) -> None:
        if len(self.pairs) != self.n_rings:
            self.fc.issues.add("texture-coordinates", self.line, self.tex_id, f"TexCoordList has {len(self.pairs)} "
                               f"textureCoordinates but {self.n_rings} ring references; they must pair up in order.")


class _Unresolved(Exception):
    """A shell member refers to a surface outside the feature being checked."""


class _Unparsed(Exception):
    """A face's coordinates are missing or not 3D numbers (reported by the XSD/dimension checks)."""


# -- helpers ----------------------------------------------------------------------------------------
def _token_counts(texts: list[str]) -> np.ndarray:
    """Whitespace-separated tokens per text: counted as spaces + 1 when all are single-spaced (C speed)."""
    if not texts:
        return np.zeros(0, dtype=np.int64)
    joined = " ".join(texts)
    if "  " in joined or "\n" in joined or "\t" in joined or "\r" in joined or joined[0] == " " or joined[-1] == " ":
        return np.fromiter(map(len, map(str.split, texts)), dtype=np.int64, count=len(texts))
    return np.fromiter(map(str.count, texts, repeat(" ")), dtype=np.int64, count=len(texts)) + 1


def _numbers(texts: list[str], expected: int) -> np.ndarray | None:
    """All numbers of ``texts`` as one array, or None when any token is not a number."""
    joined = " ".join(texts)
    if _NON_NUMBER.search(joined):
        return None
    values = np.fromstring(joined, sep=" ")
    return values if len(values) == expected else None


def _ring_values(ring: etree._Element) -> list[float] | None:
    """The coordinates of a LinearRing (posList or pos), or None when they are not 3D numbers."""
    values: list[float] = []
    for node in ring:
        if node.tag in POSITIONS:
            tokens = (node.text or "").split()
            if _srs_dimension(node) not in (None, 3) or (len(tokens) % 3 if node.tag == G["posList"] else len(tokens) != 3):
                return None
            try:
                values += map(float, tokens)
            except ValueError:
                return None
    return values or None


def _ring_points(elements: _Elements, counts: np.ndarray, exact: bool) -> tuple[list[str], np.ndarray]:
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
            values = _ring_values(ring)
            out_ids.append(gid)
            out_points.append(len(values) // 3 if values else 0)
    return out_ids, np.asarray(out_points, dtype=np.uint32)


def _parent(node: etree._Element) -> etree._Element | None:
    return node.getparent()


def _line(node: etree._Element) -> int:
    return node.sourceline or 0


def _triangle_id(tri: etree._Element) -> str | None:
    return tri.get(GML_ID) or next((r.get(GML_ID) for r in tri.iter(G["LinearRing"]) if r.get(GML_ID)), None)


def _feature_of(node: etree._Element) -> etree._Element:
    """The top-level member (child of the root) that holds ``node``."""
    while node.getparent() is not None and node.getparent().getparent() is not None:
        node = node.getparent()
    return node


def _srs_dimension(node: etree._Element | None) -> int | None:
    """srsDimension of the position element or its nearest ancestor that declares one."""
    value = _inherited(node, "srsDimension")
    if value is None:
        return None
    return int(value) if value.isdigit() else None


def _inherited(node: etree._Element | None, attribute: str) -> str | None:
    while node is not None:
        value = node.get(attribute)
        if value is not None:
            return value
        node = node.getparent()
    return None


def _non_finite(tokens: list[str]) -> list[str]:
    """The tokens that are not finite numbers (one float() per token; most lists have none)."""
    try:
        if all(map(math.isfinite, map(float, tokens))):
            return []
    except ValueError:
        pass
    return [t for t in tokens if not _finite(t)]


def _finite(token: str) -> bool:
    try:
        return math.isfinite(float(token))
    except ValueError:
        return False
