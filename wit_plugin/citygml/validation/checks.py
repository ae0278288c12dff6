"""Every check an XSD cannot express, on the finished parts of one streaming parse: the driver.

Each family of checks is a module: ``references`` (unique gml:ids, ``#id`` references),
``positions`` (3D coordinates), ``tin`` (TIN triangles), ``solids`` (closed, oriented, planar
solids) and ``textures`` (images, texture coordinates); ``parts`` gives them the part's elements
in bulk, ``context`` what they share. Elements are looked at one by one only to name a problem
(its line, its gml:id) or when a part does not have the regular layout the bulk path relies on (a
ring without a posList, a face that is an OrientableSurface, …); that general path checks the
same rules element by element (``tests/test_validate.py`` runs both on every fixture).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from lxml import etree

from ..namespaces import GML_ID
from ..reader import RawCounts, envelope_srs
from .bulk import BulkChecks
from .context import FileContext
from .crs import metre_axes
from .ids import hashes
from .names import G, IssueList, remove_keep_tail
from .parts import Elements, Part, token_counts
from .positions import PositionChecks
from .references import ReferenceChecks
from .solids import SolidChecks
from .textures import TextureChecks
from .tin import TriangleChecks


class FileCheck:
    """All checks of one file, fed part by part (``part``), concluded by ``finish``."""

    def __init__(self, path: Path, issues: IssueList, raw: RawCounts, planarity_tol: float, vertex_tol: float,
                 min_triangle_area: float):
        self.ctx, self.issues = FileContext(path, issues, raw), issues
        self.references = ReferenceChecks(self.ctx)
        self.positions = PositionChecks(self.ctx)
        self.triangles = TriangleChecks(self.ctx, min_triangle_area)
        self.solids = SolidChecks(self.ctx, vertex_tol, planarity_tol)
        self.textures = TextureChecks(self.ctx)
        self.bulk = BulkChecks(self.ctx, self.references, self.textures, min_triangle_area)
        self.entities_possible = False
        self.root: etree._Element | None = None

    def start(self, root: etree._Element) -> None:
        self.root = root
        docinfo = root.getroottree().docinfo
        if docinfo.internalDTD is not None or docinfo.doctype:
            self.entities_possible = True
            self.issues.add("xml", 1, None, "The file has a DOCTYPE. CityGML needs none; its entity declarations "
                            "are ignored (never expanded or fetched, for security).", "warning")
        gid = root.get(GML_ID)
        if gid:
            self.ctx.ids.add(hashes([gid]), np.zeros(1))

    def finish(self) -> None:
        self.references.finish()
        self.textures.finish()

    def part(self, parent: etree._Element, n: int) -> None:
        part = Part(parent, n)
        if parent is self.root:
            self._model_properties(parent, n)
        if self.entities_possible:
            self._entities(parent, n)
        elements = Elements(part)
        poslists = [node.text or "" for node in elements[G["posList"]]]
        counts = token_counts(poslists)
        self.references.add_ids(part, elements, counts)
        self.positions.check(part, elements, counts)
        self.triangles.check(part, elements, poslists, counts)
        self.solids.check(part, elements)
        rings = self.references.check(part, elements)
        self.textures.check(part, elements, rings)

    def _model_properties(self, root: etree._Element, n: int) -> None:
        """The model's CRS (its envelope) and the CRSs it defines inline (``srsName="#id"``)."""
        children = [child for child in root[:n] if isinstance(child.tag, str)]  # not the entity references
        if self.ctx.model_crs is None:
            self.ctx.model_crs = envelope_srs(children)
        for child in children:
            if child.tag.endswith("CRS"):  # core:engineeringCRS
                for crs in child.iter():
                    if crs.get(GML_ID) and isinstance(crs.tag, str) and crs.tag.endswith("CRS"):
                        uoms = [axis.get("uom", "") for axis in crs.iter(G["CoordinateSystemAxis"])]
                        self.ctx.inline_metres[crs.get(GML_ID)] = metre_axes(uoms)

    def _entities(self, parent: etree._Element, n: int) -> None:
        for child in parent[:n]:
            for ent in list(child.iter(etree.Entity)):
                self.issues.add("xml", ent.getparent().sourceline, None, f"Uses the XML entity {ent.text}: entities "
                                "are not expanded (security), so its content is missing. Write the text directly.")
                remove_keep_tail(ent)
