"""Offline CityGML 3.0 validation: XSD validity plus the checks an XSD cannot express.

Why a custom validator: XSD validation says nothing about geometry (closed, outward-oriented,
planar, simple solids; degenerate TIN triangles), about ``#id`` references or texture files. All
checks run in one streaming pass (``lxml.etree.iterparse``) so that a 1 GB file does not need
1 GB of memory:

* every top-level member of the city model is checked and XSD-validated on its own, then dropped;
* inside a member, the children of a container that grows past one batch (the triangles of a
  TIN's ``gml:patches``, the texture associations of an ``app:ParameterizedTexture``, the
  entries of an ``app:TexCoordList``) are checked and XSD-validated a batch at a time
  (``BATCH_ELEMENTS`` / ``BATCH_BYTES``), the XSD inside a small copy of their ancestors, then
  dropped (see ``_FileCheck._batch``);
* gml:ids are kept as 64-bit hashes with the point count of each ring (``_IdStore``, ~12 bytes
  per id); references and texture rings are resolved against it in batches of ``ID_BUFFER``.

Parsing never expands entities, loads DTDs or touches the network (XXE-safe).
"""
from __future__ import annotations

import csv
import hashlib
import html
import math
import re
import time
from array import array
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from difflib import get_close_matches
from functools import cache
from itertools import count, islice, pairwise
from pathlib import Path
from typing import NamedTuple, Sequence

import numpy as np
import shapely
from lxml import etree

from ..errors import InputError
from ..feedback import SILENT, Feedback
from ..fileio import atomic_file
from .schemas import content_model, load_schema, schema_namespaces

BATCH_ELEMENTS = 2048
"""A container with more children than this is streamed, and its children XSD-validated this many per call."""
BATCH_BYTES = 8 << 20
"""... or fewer, when they take more than this many bytes of the file (a container past it is streamed too)."""
ID_BUFFER = 65536
"""New ids, references or texture rings held as strings before they are resolved against the id hashes."""

GML = "http://www.opengis.net/gml/3.2"
XLINK = "http://www.w3.org/1999/xlink"
CORE = "http://www.opengis.net/citygml/3.0"
APP = "http://www.opengis.net/citygml/appearance/3.0"
GML_ID = f"{{{GML}}}id"
HREF = f"{{{XLINK}}}href"
_G = {name: f"{{{GML}}}{name}" for name in (
    "Solid", "Shell", "exterior", "interior", "surfaceMember", "Polygon", "PolygonPatch", "LinearRing", "posList",
    "pos", "lowerCorner", "upperCorner", "Triangle", "CompositeSurface", "OrientableSurface", "baseSurface",
    "Surface", "patches", "MultiSurface", "boundedBy", "Envelope")}
_A = {name: f"{{{APP}}}{name}" for name in (
    "imageURI", "TexCoordList", "textureCoordinates", "ring", "target", "ParameterizedTexture",
    "textureParameterization")}
MEMBER_TAGS = frozenset(f"{{{CORE}}}{n}" for n in (
    "cityObjectMember", "appearanceMember", "featureMember", "versionMember", "versionTransitionMember")) | {
    f"{{{GML}}}featureMember"}
STREAMED = {  # child -> the container whose children of that kind are streamed once there are many
    _G["Triangle"]: _G["patches"],
    _A["textureParameterization"]: _A["ParameterizedTexture"],
    _A["textureCoordinates"]: _A["TexCoordList"],
    _A["ring"]: _A["TexCoordList"],
}
PREFIXES = {  # conventional prefixes, for messages that read like the XML
    CORE: "core", GML: "gml", XLINK: "xlink", APP: "app",
    "http://www.opengis.net/citygml/building/3.0": "bldg", "http://www.opengis.net/citygml/construction/3.0": "con",
    "http://www.opengis.net/citygml/relief/3.0": "dem", "http://www.opengis.net/citygml/transportation/3.0": "tran",
    "http://www.opengis.net/citygml/generics/3.0": "gen", "http://www.opengis.net/citygml/cityobjectgroup/3.0": "grp",
    "http://www.opengis.net/citygml/bridge/3.0": "brid", "http://www.opengis.net/citygml/tunnel/3.0": "tun",
    "http://www.opengis.net/citygml/cityfurniture/3.0": "frn", "http://www.opengis.net/citygml/landuse/3.0": "luse",
    "http://www.opengis.net/citygml/vegetation/3.0": "veg", "http://www.opengis.net/citygml/waterbody/3.0": "wtr",
    "http://www.opengis.net/citygml/dynamizer/3.0": "dyn", "http://www.opengis.net/citygml/pointcloud/3.0": "pcl",
    "http://www.opengis.net/citygml/versioning/3.0": "vers", "urn:oasis:names:tc:ciq:xal:3": "xAL",
    "http://www.w3.org/2001/XMLSchema": "xs"}

_PARSE = dict(resolve_entities=False, no_network=True, load_dtd=False, remove_comments=True, remove_pis=True)
def _attributed(tree: etree._Element) -> tuple[list[etree._Element], list[etree._Element], bool]:
    """Elements of a subtree (itself included) with a gml:id, those with an xlink:href, and whether
    any declares srsDimension: one pass, as it is the validator's most frequent walk.

    Plain iteration, not XPath: libxml2's XPath fails ("Error in xpath expression") once a node
    set grows past its limit, which a multi-GB model's appearance member reaches.
    """
    with_id, with_href, dims = [], [], False
    for node in tree.iter(etree.Element):
        names = node.keys()
        if names:
            if GML_ID in names:
                with_id.append(node)
            if HREF in names:
                with_href.append(node)
            dims = dims or "srsDimension" in names
    return with_id, with_href, dims


_POSITIONS = (_G["posList"], _G["pos"], _G["lowerCorner"], _G["upperCorner"])
_REFERENCE_TEXTS = (_A["target"], _A["ring"])  # elements whose text is a #id reference
_QNAME_IN_MSG = re.compile(r"\{([^}]*)\}([\w.\-]+)")
_ELEMENT_IN_MSG = re.compile(r"^Element '([^']+)'")
_NCNAME = re.compile(r"^[^\W\d][\w.\-]*$")
_POINT_IN_REASON = re.compile(r"\[\s*([-+0-9.eE]+)\s+([-+0-9.eE]+)")


@dataclass
class Issue:
    """One finding, located by line and/or the ``gml:id`` of the object it concerns."""
    file: str
    check: str
    severity: str  # "error" or "warning"
    line: int | None
    gml_id: str | None
    message: str


@dataclass
class FileReport:
    """The result for one file: the row of the paper's Table 13 plus every issue behind it."""
    file: str
    valid: bool
    issues: list[Issue] = field(default_factory=list)
    size_bytes: int = 0
    seconds: float = 0.0

    @property
    def status(self) -> str:
        return "Success" if self.valid else "Fail"

    @property
    def details(self) -> str:
        """Short summary such as ``xsd: 2 errors; solid-closed: 1 error``."""
        errors = Counter(i.check for i in self.issues if i.severity == "error")
        parts = [f"{check}: {n} error{'s' if n > 1 else ''}" for check, n in errors.items()]
        warnings = sum(1 for i in self.issues if i.severity == "warning")
        if warnings:
            parts.append(f"{warnings} warning{'s' if warnings > 1 else ''}")
        return "; ".join(parts) if parts else "valid (XSD, ids, references, geometry, textures)"


def validate_files(paths: Sequence[str], schema_dir: Path, feedback: Feedback = SILENT,
                   planarity_tol: float = 0.01, vertex_tol: float = 0.001, min_triangle_area: float = 1e-6,
                   max_issues_per_check: int = 200) -> list[FileReport]:
    """Validate CityGML 3.0 files against the XSDs in ``schema_dir`` and the geometry/reference rules.

    ``planarity_tol`` (m): largest distance of a face vertex from the face's plane;
    ``vertex_tol`` (m): coordinates closer than this are the same vertex when matching shell edges;
    ``min_triangle_area`` (m²): TIN triangles at or below it are degenerate;
    ``max_issues_per_check``: issues listed per check and file (the rest are counted), so a badly
    broken 1 GB file still gives a readable report.
    """
    if not paths:
        raise InputError("No CityGML files given: choose at least one .gml file to validate.")
    files = [Path(p) for p in paths]
    for path in files:
        if not path.is_file():
            raise InputError(f"CityGML file {path} does not exist or is not a file.")
    schema = load_schema(schema_dir)
    known = schema_namespaces(schema_dir)
    total = sum(p.stat().st_size for p in files) or 1
    done = 0
    reports = []
    for path in files:
        feedback.check_canceled()
        feedback.info(f"Validating {path.name}")
        size = path.stat().st_size
        check = _FileCheck(path, schema, Path(schema_dir), known, planarity_tol, vertex_tol, min_triangle_area,
                           max_issues_per_check, feedback, lambda pos, d=done: feedback.progress(100.0 * (d + pos) / total))
        start = time.perf_counter()
        issues = check.run()
        report = FileReport(str(path), not any(i.severity == "error" for i in issues), issues, size,
                            time.perf_counter() - start)
        feedback.info(f"{path.name}: {report.status} ({report.details})")
        reports.append(report)
        done += size
        feedback.progress(100.0 * done / total)
    return reports


class _IdStore:
    """The gml:ids of one file as 64-bit hashes, each with its point count when it names a LinearRing.

    Why: a 1.6 GB model has tens of millions of ids; as Python strings in a dict they took ~100+
    bytes each (3.7 GB peak). Here an id costs 12 bytes (uint64 hash + uint32 points) in sorted
    runs; new ids wait as strings in a buffer of ``ID_BUFFER`` entries (their line kept to report a
    duplicate) and are merged in one vectorised step. Runs of similar size are merged into one
    (as a log-structured merge), so n ids cost O(n log n) and a lookup searches O(log n) runs.

    Hashes are BLAKE2b digests truncated to 64 bits: deterministic across runs, and two distinct
    ids share one with probability about n²/2⁶⁵ for n ids, i.e. 1 in 2 million for 4 million ids
    (1 in 41,000 for 30 million). A collision would show as a false duplicate id, or hide a
    reference to a missing id that happens to hash like an existing one.
    """

    def __init__(self) -> None:
        self._runs: list[tuple[np.ndarray, np.ndarray]] = []  # (sorted uint64 hashes, uint32 points)
        self._new: list[tuple[str, int | None, int]] = []  # id, line, points

    def __len__(self) -> int:
        return sum(len(keys) for keys, _ in self._runs) + len(self._new)

    @property
    def waiting(self) -> int:
        return len(self._new)

    def add(self, gid: str, line: int | None, points: int) -> None:
        self._new.append((gid, line, points))

    def merge(self) -> list[tuple[str, int | None]]:
        """Move the buffered ids into the hash runs; return the duplicates (id, line), in file order.

        A duplicate is every occurrence after the first, so its line is the one to fix.
        """
        if not self._new:
            return []
        new, self._new = self._new, []
        keys = _hashes([gid for gid, _, _ in new])
        order = np.argsort(keys, kind="stable")  # equal hashes stay in file order
        keys = keys[order]
        dup = np.r_[False, keys[1:] == keys[:-1]] | self.find_keys(keys)[0]
        duplicates = [new[i][:2] for i in np.sort(order[dup]).tolist()]
        if not dup.all():
            points = np.array([p for _, _, p in new], dtype=np.uint32)[order]
            self._runs.append((keys[~dup], points[~dup]))
        while len(self._runs) > 1 and len(self._runs[-2][0]) <= 2 * len(self._runs[-1][0]):
            self._runs.append(_merge_runs(self._runs.pop(), self._runs.pop()))
        return duplicates

    def find(self, gids: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """(found, points) for each id, among the merged ids (call ``merge`` first)."""
        return self.find_keys(_hashes(gids))

    def find_keys(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        found = np.zeros(len(keys), dtype=bool)
        points = np.zeros(len(keys), dtype=np.uint32)
        for run_keys, run_points in self._runs:
            at = np.minimum(np.searchsorted(run_keys, keys), len(run_keys) - 1)
            hit = run_keys[at] == keys
            found |= hit
            points[hit] = run_points[at[hit]]
        return found, points


def _merge_runs(new: tuple[np.ndarray, np.ndarray], old: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One sorted run (hashes, points) from two whose hashes differ: linear, and no temporary copy of either."""
    at = np.searchsorted(old[0], new[0])
    at += np.arange(len(at))  # where the new run's hashes land in the merged run
    from_new = np.zeros(len(old[0]) + len(at), dtype=bool)
    from_new[at] = True
    merged = []
    for n, o in zip(new, old):
        out = np.empty(len(from_new), dtype=o.dtype)
        out[at] = n
        out[~from_new] = o
        merged.append(out)
    return merged[0], merged[1]


def _hashes(gids: Sequence[str]) -> np.ndarray:
    """64-bit BLAKE2b hashes of ``gids`` (uint64)."""
    blake2b = hashlib.blake2b
    return np.frombuffer(b"".join([blake2b(g.encode(), digest_size=8).digest() for g in gids]), dtype="<u8")


@dataclass(eq=False)
class _Stream:
    """A container's children of the streamed kinds still in place, counted until they fill a batch."""
    start: int  # file position at the first of them
    count: int = 0
    streaming: bool = False  # a batch was taken out: the rest goes out at the container's end too
    pairs: _TexCoordPairs | None = None  # a streamed TexCoordList's coordinates waiting for their rings


class _FileCheck:
    """All checks of one file in one streaming pass."""

    def __init__(self, path: Path, schema: etree.XMLSchema, schema_dir: Path, known_ns: frozenset[str],
                 planarity_tol: float, vertex_tol: float, min_triangle_area: float, max_issues: int,
                 feedback: Feedback, on_progress):
        self.path, self.name, self.schema, self.schema_dir = path, str(path), schema, schema_dir
        self.known_ns = known_ns
        self.planarity_tol, self.vertex_tol, self.min_area = planarity_tol, vertex_tol, min_triangle_area
        self.max_issues, self.feedback, self.on_progress = max_issues, feedback, on_progress
        self.batch_elements, self.batch_bytes, self.id_buffer = BATCH_ELEMENTS, BATCH_BYTES, ID_BUFFER
        self.issues: list[Issue] = []
        self._per_check: Counter = Counter()
        self.ids = _IdStore()
        self.refs: list[tuple[str, int | None, str]] = []  # referenced id, line, how it is referenced
        self.tex_rings: list[tuple[str, int, int | None, str | None]] = []  # ring id, texture pairs, line, texture
        self.forward_refs: dict[str, tuple[int | None, str]] = {}  # to ids not seen yet: resolved at the end
        self.forward_tex_rings: list[tuple[str, int, int | None, str | None]] = []
        self.images: set[str] = set()
        self.ade_reported: set[str] = set()
        self.entities_possible = False
        self.model_crs: str | None = None
        self.solids: list[tuple[_Where, list]] = []
        self.pending: etree._Element | None = None  # checked member waiting to be validated and dropped
        self.triangles: list[tuple[str | None, int | None, list[float]]] = []
        self.streams: dict[etree._Element, _Stream] = {}  # open containers of streamed children
        self.stand_ins: dict[int, etree._Element] = {}  # hidden first child of a run, by its marker's number
        self._markers = count()
        self.pos = 0  # file position of the parser at the last streamed child

    # -- reporting -------------------------------------------------------------------------------
    def add(self, check: str, line: int | None, gml_id: str | None, message: str, severity: str = "error") -> None:
        self._per_check[check, severity] += 1
        if self._per_check[check, severity] <= self.max_issues:
            self.issues.append(Issue(self.name, check, severity, line, gml_id, message))

    # -- driver ----------------------------------------------------------------------------------
    def run(self) -> list[Issue]:
        try:
            root_tag = next(etree.iterparse(str(self.path), events=("start",), **_PARSE))[1].tag
            with open(self.path, "rb") as stream:
                events = etree.iterparse(stream, events=("end",), tag={root_tag, *MEMBER_TAGS, *STREAMED,
                                                                       *STREAMED.values()}, **_PARSE)
                for n, (_, el) in enumerate(events):
                    if n == 0:
                        self._start_document(el)
                    parent = el.getparent()
                    if parent is not None and STREAMED.get(el.tag) == parent.tag:
                        self.pos = stream.tell()
                        self._stream_child(el, parent)
                    else:
                        state = self.streams.pop(el, None)
                        if state is not None:
                            self._end_container(el, state)
                        if parent is None:
                            self._release()
                            self._check_unit(el)
                            self._validate(el)
                        elif parent.getparent() is None and el.tag in MEMBER_TAGS:
                            self._release()
                            self._check_unit(el)
                            self.pending = el
                    if n % 256 == 0:
                        self.feedback.check_canceled()
                        self.on_progress(stream.tell())
        except StopIteration:
            self.add("xml", None, None, "The file is empty.")
        except etree.XMLSyntaxError as exc:
            last = exc.error_log.last_error if exc.error_log else None
            self.add("xml", (last.line if last else exc.lineno) or None, None, f"Not well-formed XML: "
                     f"{(last.message if last else exc.msg).strip()}. Nothing after this point was checked.")
        self._release()
        self._flush_triangles()
        self._flush_solids()
        self._resolve(final=True)
        for (check, severity), number in self._per_check.items():
            if number > self.max_issues:
                self.issues.append(Issue(self.name, check, severity, None, None,
                                         f"... and {number - self.max_issues} more {check} {severity}s not listed."))
        return self.issues

    def _start_document(self, el: etree._Element) -> None:
        envelope = el.getroottree().getroot().find(f"{_G['boundedBy']}/{_G['Envelope']}")
        self.model_crs = envelope.get("srsName") if envelope is not None else None
        docinfo = el.getroottree().docinfo
        if docinfo.internalDTD is not None or docinfo.doctype:
            self.entities_possible = True
            self.add("xml", 1, None, "The file has a DOCTYPE. CityGML needs none; its entity declarations are "
                     "ignored (never expanded or fetched, for security).", "warning")

    # -- ids and references ----------------------------------------------------------------------
    def _resolve(self, final: bool = False) -> None:
        """Merge the buffered ids (reporting duplicates), then resolve the buffered references and rings.

        References to ids not seen yet wait as strings until the end of the file (``final``).
        """
        for gid, line in self.ids.merge():
            self.add("duplicate-id", line, gid, f"gml:id '{gid}' is used more than once; every gml:id in a file "
                     "must be unique.")
        refs, self.refs = self.refs, []
        for (ref, line, how), found in zip(refs, self.ids.find([r for r, _, _ in refs])[0]):
            if not found:
                self.forward_refs.setdefault(ref, (line, how))
        tex_rings, self.tex_rings = self.tex_rings, []
        self._compare_tex(tex_rings, self.forward_tex_rings)
        if final:
            forward = self.forward_refs
            for (ref, (line, how)), found in zip(forward.items(), self.ids.find(list(forward))[0]):
                if not found:
                    self.add("reference", line, None, f"{how} '#{ref}' points to no gml:id in this file.")
            self._compare_tex(self.forward_tex_rings, [])

    def _compare_tex(self, tex_rings: list[tuple[str, int, int | None, str | None]], unknown: list) -> None:
        """Compare texture pairs with the points of the rings already seen; put the others in ``unknown``."""
        found, points = self.ids.find([r[0] for r in tex_rings])
        for (ring_id, pairs, line, tex_id), ok, n in zip(tex_rings, found.tolist(), points.tolist()):
            if not ok:
                unknown.append((ring_id, pairs, line, tex_id))
            elif n and pairs != n:
                self.add("texture-coordinates", line, tex_id, f"{pairs} texture coordinate pairs for ring #{ring_id}, "
                         f"which has {n} points; there must be one pair per point (closing point included).")

    # -- members and streamed children -------------------------------------------------------------
    def _check_unit(self, el: etree._Element) -> None:
        """Check a member, the root or a batch of streamed children where it stands (not the hidden stand-ins:
        they were checked with their batch)."""
        rings = self._scan(el)
        self._check_triangles(el, rings)
        self._check_solids(el, rings)
        self._check_textures(el)
        if max(self.ids.waiting, len(self.refs), len(self.tex_rings)) >= self.id_buffer:
            self._resolve()

    def _release(self) -> None:
        """XSD-validate the previous member on its own, then drop it from the parsed tree.

        Done one member late: libxml2 may still be appending the member's tail text right after its
        end event, and moving that text node away under the parser corrupts memory.
        """
        el, self.pending = self.pending, None
        if el is None:
            return
        root = el.getparent()
        prev = el.getprevious()
        if prev is None or prev.tag != el.tag or len(prev) or prev.attrib:
            el.addprevious(etree.Element(el.tag))  # an empty member keeps the root's structure valid
        mini = etree.Element(root.tag, nsmap=root.nsmap)
        _move_into(el, mini)  # moves the member out of the parsed tree: this is what frees its memory
        self._validate(mini)

    def _stream_child(self, el: etree._Element, container: etree._Element) -> None:
        """Leave a container's children in place until they fill a batch, then process them together.

        ``el`` itself stays until the next batch: libxml2 may still be appending its tail text (see
        ``_release``). So a container never holds more than a batch, whatever its size.
        """
        state = self.streams.get(container)
        if state is None:
            state = self.streams[container] = _Stream(self.pos)
        state.count += 1
        if state.count > self.batch_elements or self.pos - state.start > self.batch_bytes:
            earlier = [s for s in el.itersiblings(preceding=True) if STREAMED.get(s.tag) == container.tag]
            self._batch(container, state, earlier[::-1])
            state.count, state.start = 1, self.pos

    def _end_container(self, container: etree._Element, state: _Stream) -> None:
        """A streamed container's last children form the last batch; a small one is left to its member."""
        if state.streaming:
            self._batch(container, state, [c for c in container if STREAMED.get(c.tag) == container.tag])
            if state.pairs is not None:
                state.pairs.close()

    def _batch(self, container: etree._Element, state: _Stream, children: list[etree._Element]) -> None:
        """Check a container's children together, then take them out of the parsed tree.

        They are checked in a neutral holder put in their place, so the checks see their real
        ancestors (owner ids, inherited srsName) at the cost of one walk per batch. The first child
        of each run of one kind then stays as the container's stand-in, hidden behind a marker
        comment (invisible to the checks; the parse drops the file's own comments) until the
        enclosing member is validated: the schema then sees the container as in the file
        (minOccurs, order) and reports the stand-in's errors on its real line. The others are
        XSD-validated together in a copy of their context (``_context``), then dropped.
        """
        if not children:
            return  # a single child past BATCH_BYTES: it goes with the next batch
        if not state.streaming:
            state.streaming = True
            if container.tag == _A["TexCoordList"]:
                state.pairs = _TexCoordPairs(self, container)
        holder = etree.Element("batch")
        children[0].addprevious(holder)
        root, copy = self._context(holder)
        holder.extend(children)  # within the parsed document: cheap
        self._check_unit(holder)
        if state.pairs is not None:
            for child in holder:
                state.pairs.add(child)
        before = holder.getprevious()
        run = self._stand_in(before) if before is not None and before.tag is etree.Comment else before
        run_tag = run.tag if run is not None else None
        batch = []
        for child in list(holder):
            if child.tag != run_tag:
                key = next(self._markers)
                self.stand_ins[key] = child
                holder.addprevious(etree.Comment(str(key)))
                holder.remove(child)
            else:
                batch.append(child)
            run_tag = child.tag
        for child in batch:
            _move_into(child, copy)
        container.remove(holder)  # empty now: removing it with its children would re-link them all
        if batch:
            self._validate(root)

    def _stand_in(self, node: etree._Element) -> etree._Element:
        """The hidden child that the marker ``node`` stands for."""
        return self.stand_ins[int(node.text)]

    def _context(self, first: etree._Element) -> tuple[etree._Element, etree._Element]:
        """A copy of ``first``'s ancestors in which siblings of ``first`` are validated as in the file.

        Each copy holds one empty element per sibling before the path: a content model looks only
        at the names of the earlier siblings, so this is enough for the schema to check the batch
        in place, and the copy stays a few dozen elements. The copies have no source line: their own
        errors (empty content) are dropped by ``_validate``.
        """
        path = [first, *first.iterancestors()][::-1]
        root = copy = etree.Element(path[0].tag, nsmap=first.nsmap)
        for depth, (node, child) in enumerate(pairwise(path)):
            if depth:
                copy = etree.SubElement(copy, node.tag, node.attrib)
            for sibling in reversed(list(child.itersiblings(preceding=True))):
                tag = self._stand_in(sibling).tag if sibling.tag is etree.Comment else sibling.tag
                if isinstance(tag, str):  # not an entity reference (reported by _scan)
                    etree.SubElement(copy, tag)
        return root, copy

    def _restore(self, tree: etree._Element) -> None:
        """Put the hidden stand-ins back in place of their markers (they are validated with ``tree``)."""
        for marker in list(tree.iter(etree.Comment)):
            stand_in = self.stand_ins.pop(int(marker.text))
            self._restore(stand_in)
            marker.getparent().replace(marker, stand_in)

    def _scan(self, el: etree._Element) -> dict:
        """ids, references and coordinate dimensions; returns the parsed coordinates of every ring."""
        if self.entities_possible:
            for ent in list(el.iter(etree.Entity)):
                self.add("xml", ent.getparent().sourceline, None, f"Uses the XML entity {ent.text}: entities are not "
                         "expanded (security), so its content is missing. Write the text directly.")
                _remove_keep_tail(ent)
        rings: dict = {}
        with_id, with_href, dims = _attributed(el)
        for node in el.iter(*_POSITIONS):
            tokens = (node.text or "").split()
            ok = self._check_dimension(node, len(tokens), dims)
            parent = node.getparent()
            if parent.tag == _G["LinearRing"]:
                try:
                    values = list(map(float, tokens)) if ok else None
                except ValueError:
                    values = None  # not numbers: the XSD check reports it
                if parent in rings:
                    if rings[parent] is not None and values is not None:
                        rings[parent].extend(values)
                    else:
                        rings[parent] = None
                else:
                    rings[parent] = values
        for node in with_id:
            gid = node.get(GML_ID)
            if not _NCNAME.match(gid):
                self.add("xsd", node.sourceline, gid, f"gml:id '{gid}' is not a valid XML name (it must start with a "
                         "letter or '_' and contain no spaces or ':').")
            values = rings.get(node)
            self.ids.add(gid, node.sourceline, len(values) // 3 if values else 0)
        for node in with_href:
            href = node.get(HREF)
            if href.startswith("#"):
                self.refs.append((href[1:], node.sourceline, f"xlink:href of {_qname(node.tag)}"))
        for node in el.iter(*_REFERENCE_TEXTS):
            text = (node.text or "").strip()
            if text.startswith("#"):
                self.refs.append((text[1:], node.sourceline, _qname(node.tag)))
        return rings

    def _check_dimension(self, node: etree._Element, count: int, any_declared: bool) -> bool:
        """True when the position element holds 3D positions; reports it otherwise.

        A geometry in its own CRS (e.g. an address point in EPSG:4326, as in the official
        examples) gets a warning: its dimension follows that CRS, which cannot be looked up offline.
        """
        dim = _srs_dimension(node, any_declared)
        if dim is not None and dim != 3:
            problem = f"{_qname(node.tag)} has srsDimension=\"{dim}\": coordinates must be 3D (x y z)."
        elif node.tag == _G["posList"] and count % 3:
            problem = f"gml:posList has {count} numbers, not a multiple of 3: every position must be 3D (x y z)."
        elif node.tag != _G["posList"] and count != 3:
            problem = f"{_qname(node.tag)} has {count} numbers: a position must be 3D (x y z)."
        else:
            return True
        own_crs = _inherited(node, "srsName")
        if dim is None and own_crs and own_crs != self.model_crs and count % 2 == 0:
            self.add("dimension", node.sourceline, _owner_id(node), f"{problem[:-1]}, unless its own CRS {own_crs} "
                     "is 2D; city-object geometry should be 3D in the model's CRS.", "warning")
        else:
            self.add("dimension", node.sourceline, _owner_id(node), problem)
        return False

    def _validate(self, tree: etree._Element) -> None:
        """XSD-validate ``tree`` with its stand-ins put back and its gml:ids neutral (see ``_neutral_ids``).

        Errors without a source line are on our copies or empty placeholders: dropped, since what
        they stand for is validated where it really is.
        """
        self._restore(tree)
        aliases = _neutral_ids(tree)
        try:
            if self.schema.validate(tree):
                return
        except etree.XMLSchemaValidateError as exc:
            self.add("xsd", tree.sourceline, None, f"XSD validation could not run on this part: {exc}")
            return
        error_lines: set[int] = set()
        for err in self.schema.error_log:
            if not err.line or ("list type" in err.message and err.line in error_lines):
                continue  # libxml2 repeats a bad list item as a bad list: report it once
            error_lines.add(err.line)
            self._xsd_issue(err.line, err.message, tree, aliases)

    def _xsd_issue(self, line: int, message: str, validated: etree._Element, aliases: dict[str, str]) -> None:
        match = _ELEMENT_IN_MSG.match(message)
        tag = match.group(1) if match else ""
        ns = tag[1:].split("}")[0] if tag.startswith("{") else ""
        if ns and ns not in self.known_ns:
            if ns not in self.ade_reported:
                self.ade_reported.add(ns)
                self.add("ade", line, None, f"Uses ADE namespace {ns} whose schema is not available, so its "
                         f"elements (first: {tag.split('}')[1]}) cannot be validated. Add the ADE's XSD to the "
                         "schema folder (and import it in citygml3-all.xsd) or remove the ADE content.")
            return
        if self._per_check["xsd", "error"] >= self.max_issues:
            self.add("xsd", line, None, message)
            return
        node = next((n for n in validated.iter(tag) if n.sourceline == line), None) if tag else None
        gml_id = _owner_id(node) if node is not None else None
        gml_id = aliases.get(gml_id, gml_id)
        text = _short(message)
        if node is not None and "This element is not expected" in message:
            parent = node.getparent()
            model = content_model(str(self.schema_dir.resolve()))
            missing = model.missing_required(parent.tag, [c.tag for c in parent if isinstance(c.tag, str)])
            expected = re.findall(r"\{[^}]*\}[\w.\-]+", message.split("Expected is", 1)[-1])
            if missing:
                text = (f"{_short(parent.tag)} is missing the required element {_short(missing[0])} "
                        f"(found {_short(tag)} where {_short(missing[0])} was expected).")
            elif tag not in model.local_names:
                guess = get_close_matches(_short(tag), [_short(e) for e in expected], n=1)
                text = (f"Unknown element {_short(tag)} in {_short(parent.tag)} (no schema defines it)"
                        + (f"; did you mean {guess[0]}?" if guess else ".")
                        + (f" Expected one of: {', '.join(_short(e) for e in expected)}." if expected else ""))
        self.add("xsd", line, gml_id, text)

    # -- TIN triangles ---------------------------------------------------------------------------
    def _check_triangles(self, el: etree._Element, rings: dict) -> None:
        """Queue every triangle of ``el``; they are checked in batches (numpy pays off on thousands)."""
        for tri in el.iter(_G["Triangle"]):
            gid = tri.get(GML_ID) or next((r.get(GML_ID) for r in tri.iter(_G["LinearRing"]) if r.get(GML_ID)), None)
            exterior = next((r for e in tri.iterchildren(_G["exterior"]) for r in e.iterchildren(_G["LinearRing"])), None)
            values = rings.get(exterior) if exterior is not None else None
            if values is not None:
                self.triangles.append((gid, tri.sourceline, values))
        if len(self.triangles) >= 4096:
            self._flush_triangles()

    def _flush_triangles(self) -> None:
        for gid, line, values in self.triangles:
            if len(values) != 12 or values[:3] != values[9:]:
                self.add("degenerate-triangle", line, gid, f"Triangle has {len(values) // 3} positions; it needs 4 "
                         "(3 corners and the first repeated).")
        ok = [t for t in self.triangles if len(t[2]) == 12]
        if ok:
            pts = np.array([t[2] for t in ok]).reshape(-1, 4, 3)
            area = 0.5 * np.linalg.norm(np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0]), axis=1)
            for i in np.flatnonzero(area <= self.min_area):
                gid, line, _ = ok[i]
                self.add("degenerate-triangle", line, gid, f"Triangle is degenerate (area {area[i]:.3g} m² ≤ "
                         f"{self.min_area:g} m²): its corners coincide or are collinear.")
        self.triangles = []

    # -- textures --------------------------------------------------------------------------------
    def _check_textures(self, el: etree._Element) -> None:
        for node in el.iter(_A["imageURI"]):
            uri = (node.text or "").strip()
            if uri in self.images:
                continue
            self.images.add(uri)
            if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]+://", uri):
                self.add("texture-image", node.sourceline, _owner_id(node), f"Texture image {uri} is remote and was "
                         "not checked.", "warning")
            elif not uri or not (self.path.parent / uri).is_file():
                self.add("texture-image", node.sourceline, _owner_id(node), f"Texture image '{uri}' does not exist "
                         f"(looked for {self.path.parent / uri}).")
        for tcl in el.iter(_A["TexCoordList"]):
            if any(child.tag is etree.Comment for child in tcl):
                continue  # streamed: its entries were paired as they came
            pairs = _TexCoordPairs(self, tcl)
            for child in tcl:
                pairs.add(child)
            pairs.close()

    # -- solids ----------------------------------------------------------------------------------
    def _check_solids(self, feature: etree._Element, rings: dict) -> None:
        """Queue the feature's solids; they are checked in batches (numpy pays off on thousands of faces)."""
        for solid in feature.iter(_G["Solid"]):
            faces: list = []
            try:
                for shell in solid.iterfind(f"{_G['exterior']}/{_G['Shell']}"):
                    self._collect_faces(shell, False, feature, rings, faces)
            except _Unresolved as exc:
                self.add("solid-closed", solid.sourceline, solid.get(GML_ID), f"Solid not checked: its surface "
                         f"#{exc} is not defined in the same feature.", "warning")
                continue
            except _Unparsed:
                continue  # coordinates that are not numbers: the XSD check reports it
            if faces:
                self.solids.append((_Where(solid.sourceline, solid.get(GML_ID), _label(solid)), faces))
        if len(self.solids) >= 2000:
            self._flush_solids()

    def _flush_solids(self) -> None:
        if self.solids:
            _SolidCheck(self, self.solids).run()
        self.solids = []

    def _collect_faces(self, node: etree._Element, reverse: bool, feature: etree._Element, rings: dict,
                       out: list) -> None:
        """Polygons of a shell/composite/orientable surface as (polygon element, [rings]), in shell orientation."""
        for child in node:
            if child.tag not in (_G["surfaceMember"], _G["baseSurface"], _G["patches"]):
                continue
            targets = list(child)
            href = child.get(HREF)
            if not targets and href and href.startswith("#"):
                found = feature.xpath("descendant-or-self::*[@gml:id=$i]", i=href[1:], namespaces={"gml": GML})
                if not found:
                    raise _Unresolved(href[1:])
                targets = found[:1]
            for surface in targets:
                if surface.tag in (_G["Polygon"], _G["PolygonPatch"]):
                    ring_nodes = [r for part in surface for r in part if r.tag == _G["LinearRing"]
                                  and part.tag in (_G["exterior"], _G["interior"])]
                    coords = [rings.get(r) for r in ring_nodes]
                    if not ring_nodes or any(c is None or len(c) % 3 for c in coords):
                        raise _Unparsed()
                    arrays = [np.asarray(c).reshape(-1, 3) for c in coords]
                    out.append((_Where(surface.sourceline, _owner_id(surface), _label(surface)),
                                [a[::-1] for a in arrays] if reverse else arrays))
                elif surface.tag == _G["OrientableSurface"]:
                    self._collect_faces(surface, reverse ^ (surface.get("orientation") == "-"), feature, rings, out)
                elif surface.tag in (_G["CompositeSurface"], _G["Surface"], _G["MultiSurface"], _G["Shell"]):
                    self._collect_faces(surface, reverse, feature, rings, out)


class _TexCoordPairs:
    """Pairs the textureCoordinates of a TexCoordList with its rings, in order, as they come.

    All coordinates come before the rings, so a streamed list keeps only the number of pairs and
    the line of each coordinate list (16 bytes) until its ring arrives, not the elements.
    """

    def __init__(self, fc: _FileCheck, tcl: etree._Element):
        self.fc, self.line, self.tex_id = fc, tcl.sourceline, _owner_id(tcl)
        self.pairs = array("q")  # (s t) pairs per coordinate list; minus the number of values when it is odd
        self.lines = array("q")
        self.faults: dict[int, list[str]] = {}  # coordinate list -> its non-finite values (first three)
        self.n_rings = 0

    def add(self, node: etree._Element) -> None:
        if node.tag == _A["textureCoordinates"]:
            tokens = (node.text or "").split()
            bad = _non_finite(tokens)
            if bad:
                self.faults[len(self.pairs)] = bad[:3]
            self.pairs.append(-len(tokens) if len(tokens) % 2 else len(tokens) // 2)
            self.lines.append(node.sourceline or 0)
        elif node.tag == _A["ring"]:
            self.n_rings += 1
            if self.n_rings <= len(self.pairs):
                self._pair(self.n_rings - 1, (node.text or "").strip().lstrip("#"))

    def _pair(self, k: int, ring_id: str) -> None:
        fc, pairs, line = self.fc, self.pairs[k], self.lines[k] or None
        bad = self.faults.pop(k, None)
        if bad:
            fc.add("texture-coordinates", line, self.tex_id, f"Texture coordinates for ring #{ring_id} contain "
                   f"{', '.join(repr(b) for b in bad)}: each must be a finite number.")
        if pairs < 0:
            fc.add("texture-coordinates", line, self.tex_id, f"Texture coordinates for ring #{ring_id} have an odd "
                   f"number of values ({-pairs}); they are (s t) pairs.")
        else:
            fc.tex_rings.append((ring_id, pairs, line, self.tex_id))

    def close(self) -> None:
        if len(self.pairs) != self.n_rings:
            self.fc.add("texture-coordinates", self.line, self.tex_id, f"TexCoordList has {len(self.pairs)} "
                        f"textureCoordinates but {self.n_rings} ring references; they must pair up in order.")


class _Where(NamedTuple):
    """Where a solid or face is, kept instead of the element so that checked members can be freed."""
    line: int | None
    gml_id: str | None
    label: str


class _Unresolved(Exception):
    """A shell member refers to a surface outside the feature being checked."""


class _Unparsed(Exception):
    """A face's coordinates are missing or not 3D numbers (reported by the XSD/dimension checks)."""


class _SolidCheck:
    """Closedness, orientation, planarity and simplicity of a batch of solids, vectorised over the batch."""

    def __init__(self, fc: _FileCheck, solids: list):
        self.fc, self.tol = fc, fc.vertex_tol
        self.solids = solids

    def run(self) -> None:
        fc = self.fc
        verts, vert_ring, ring_face, face_solid, face_nodes, origins = [], [], [], [], [], []
        self.broken: set[int] = set()  # solids with a face dropped for a bad ring: topology would mislead
        for s, (solid, faces) in enumerate(self.solids):
            origin = faces[0][1][0][0]
            origins.append(origin)
            for node, rings in faces:
                good = []
                for ring in rings:
                    if len(ring) < 4:
                        fc.add("polygon", node.line, node.gml_id, f"A ring of face {node.label} has "
                               f"{len(ring)} positions; a ring needs at least 4 (3 corners and the first repeated).")
                    elif np.abs(ring[0] - ring[-1]).max() > self.tol:
                        fc.add("polygon", node.line, node.gml_id, f"A ring of face {node.label} is not "
                               "closed: its last position must repeat the first.")
                    else:
                        good.append(ring[:-1] - origin)
                if len(good) != len(rings):
                    self.broken.add(s)
                    continue
                f = len(face_nodes)
                face_nodes.append(node)
                face_solid.append(s)
                for ring in good:
                    vert_ring.append(np.full(len(ring), len(ring_face)))
                    ring_face.append(f)
                    verts.append(ring)
        if not verts:
            return
        self.v = np.concatenate(verts)
        self.vert_ring = np.concatenate(vert_ring)
        self.ring_face = np.asarray(ring_face)
        self.face_solid = np.asarray(face_solid)
        self.face_nodes, self.origins = face_nodes, origins
        ring_len = np.bincount(self.vert_ring)
        ring_start = np.concatenate([[0], np.cumsum(ring_len)[:-1]])
        self.nxt = np.arange(len(self.v)) + 1
        self.nxt[ring_start + ring_len - 1] = ring_start
        self.vert_face = self.ring_face[self.vert_ring]
        self._faces()
        self._topology()

    def _faces(self) -> None:
        """Area, planarity and self-intersection of every face; signed volume of every solid."""
        fc, v, w, vf = self.fc, self.v, self.v[self.nxt], self.vert_face
        nfaces = len(self.face_nodes)
        terms = np.column_stack([(v[:, 1] - w[:, 1]) * (v[:, 2] + w[:, 2]), (v[:, 2] - w[:, 2]) * (v[:, 0] + w[:, 0]),
                                 (v[:, 0] - w[:, 0]) * (v[:, 1] + w[:, 1])])
        normal = np.column_stack([np.bincount(vf, terms[:, k], nfaces) for k in range(3)])  # 2 × area vector
        count = np.bincount(vf, minlength=nfaces)
        centroid = np.column_stack([np.bincount(vf, v[:, k], nfaces) for k in range(3)]) / count[:, None]
        length = np.linalg.norm(normal, axis=1)
        flat = length / 2 <= max(self.tol ** 2, 1e-12)
        unit = normal / np.where(flat, 1.0, length)[:, None]
        dist = np.abs(((v - centroid[vf]) * unit[vf]).sum(axis=1))
        face_start = np.flatnonzero(np.r_[True, vf[1:] != vf[:-1]])
        worst = np.maximum.reduceat(dist, face_start)
        self.volume = np.bincount(self.face_solid, (centroid * normal).sum(axis=1), len(self.solids)) / 6.0
        self.flat_solid = set(self.face_solid[flat].tolist())
        for f in np.flatnonzero(flat):
            node, pts = self.face_nodes[f], v[vf == f]
            spread = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
            if len(spread) > 1 and spread[1] > self.tol * np.sqrt(len(pts)):
                fc.add("self-intersection", node.line, node.gml_id, f"Face {node.label} intersects itself "
                       "(its signed area is zero although its points span a plane: a bow-tie or figure-eight ring).")
            else:
                fc.add("polygon", node.line, node.gml_id, f"Face {node.label} has zero area (its points "
                       "coincide or are collinear).")
        for f in np.flatnonzero(~flat & (worst > fc.planarity_tol)):
            node = self.face_nodes[f]
            fc.add("planarity", node.line, node.gml_id, f"Face {node.label} is not planar: a vertex lies "
                   f"{worst[f]:.3f} m from the face's plane (tolerance {fc.planarity_tol:g} m).")
        # self-intersection: each face projected on the coordinate plane its normal is closest to
        keep = ~flat[vf]
        axis = np.argmax(np.abs(normal), axis=1)
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        idx = np.flatnonzero(keep)
        xy = np.column_stack([v[idx, a1[vf[idx]]], v[idx, a2[vf[idx]]]])
        if not len(idx):
            return
        ring_ids = self.vert_ring[idx]
        _, ring_seq = np.unique(ring_ids, return_inverse=True)
        linear = shapely.linearrings(xy, indices=ring_seq)
        ring_of = np.unique(ring_ids)
        faces_of_rings = self.ring_face[ring_of]
        _, face_seq = np.unique(faces_of_rings, return_inverse=True)
        polys = shapely.polygons(linear, indices=face_seq)
        face_list = np.unique(faces_of_rings)
        for k in np.flatnonzero(~shapely.is_valid(polys)):
            f = face_list[k]
            node = self.face_nodes[f]
            reason = shapely.is_valid_reason(polys[k])
            where = ""
            m = _POINT_IN_REASON.search(reason)
            if m:
                p = np.zeros(3)
                p[a1[f]], p[a2[f]] = float(m.group(1)), float(m.group(2))
                n, c = unit[f], centroid[f]
                p[axis[f]] = c[axis[f]] - (n[a1[f]] * (p[a1[f]] - c[a1[f]]) + n[a2[f]] * (p[a2[f]] - c[a2[f]])) / n[axis[f]]
                where = " near " + _xyz(p + self.origins[self.face_solid[f]])
            fc.add("self-intersection", node.line, node.gml_id, f"Face {node.label} intersects itself"
                   f"{where} ({reason.split('[')[0].strip()}).")

    def _topology(self) -> None:
        """Every edge in exactly two faces, once in each direction; then outward by signed volume."""
        v = self.v
        vs = self.face_solid[self.vert_face]
        key = np.column_stack([vs, np.round(v / self.tol).astype(np.int64)])
        _, vid = np.unique(key, axis=0, return_inverse=True)
        vid = vid.ravel()
        suspicious = self._suspicious(vid)
        for s, (solid, _) in enumerate(self.solids):
            if s in self.broken:
                continue
            if s in suspicious:
                mask = vs == s
                self._explain(s, solid, np.flatnonzero(mask), _tolerant_ids(v[mask], self.tol))
            elif s not in self.flat_solid:
                self._outward(s, solid)

    def _suspicious(self, vid: np.ndarray) -> set[int]:
        a, b = vid, vid[self.nxt]
        real = a != b
        solid_of_edge = self.face_solid[self.vert_face][real]
        a, b = a[real], b[real]
        m = int(vid.max()) + 1
        _, inv, cnt = np.unique(np.minimum(a, b) * m + np.maximum(a, b), return_inverse=True, return_counts=True)
        _, dinv, dcnt = np.unique(a * m + b, return_inverse=True, return_counts=True)
        bad = (cnt[inv.ravel()] != 2) | (dcnt[dinv.ravel()] != 1)
        return set(solid_of_edge[bad].tolist())

    def _explain(self, s: int, solid: _Where, vidx: np.ndarray, local_ids: list[int]) -> None:
        """Report why a solid failed the fast edge test (after matching vertices at the tolerance)."""
        fc, sid = self.fc, solid.gml_id
        ids = dict(zip(vidx.tolist(), local_ids))
        undirected: dict = defaultdict(list)
        for i in vidx.tolist():
            a, b = ids[i], ids[self.nxt[i]]
            if a != b:
                undirected[min(a, b), max(a, b)].append((int(self.vert_face[i]), a < b, i))
        open_edges = [(k, uses) for k, uses in undirected.items() if len(uses) != 2]
        if open_edges:
            (_, uses), n = open_edges[0], len(open_edges)
            i = uses[0][2]
            faces = ", ".join(sorted({self.face_nodes[f].label for f, _, _ in uses}))
            ends = f"{_xyz(self.v[i] + self.origins[s])} – {_xyz(self.v[self.nxt[i]] + self.origins[s])}"
            what = "is used by only one face: the shell has a hole" if len(uses) == 1 else \
                f"is shared by {len(uses)} faces"
            fc.add("solid-closed", solid.line, sid, f"Solid {sid or ''} is not closed: edge {ends} (face "
                   f"{faces}) {what}" + (f"; {n - 1} more such edges." if n > 1 else "."))
            return
        if all(d1 != d2 for (_, d1, _), (_, d2, _) in undirected.values()):
            if s not in self.flat_solid:
                self._outward(s, solid)  # only the fast vertex matching was fooled
            return
        # closed: find the faces whose orientation disagrees with their neighbours
        neighbours: dict = defaultdict(list)
        for (f1, d1, _), (f2, d2, _) in undirected.values():
            neighbours[f1].append((f2, d1 == d2))
            neighbours[f2].append((f1, d1 == d2))
        parity: dict[int, int] = {}
        for start in neighbours:
            if start in parity:
                continue
            parity[start], todo = 0, [start]
            while todo:
                f = todo.pop()
                for g, flip in neighbours[f]:
                    want = parity[f] ^ flip
                    if g not in parity:
                        parity[g] = want
                        todo.append(g)
                    elif parity[g] != want:
                        fc.add("solid-orientation", solid.line, sid, f"Solid {sid or ''} cannot be oriented "
                               "consistently (its shell is not a proper closed surface).")
                        return
        groups = [sorted(f for f, p in parity.items() if p == k) for k in (0, 1)]
        minority = min(groups, key=len)
        names = ", ".join(self.face_nodes[f].label for f in minority[:10])
        fc.add("solid-orientation", solid.line, sid, f"Solid {sid or ''}: face(s) {names} are oriented "
               "opposite to their neighbours; reverse their vertex order so all faces point outwards.")

    def _outward(self, s: int, solid: _Where) -> None:
        vol, sid = self.volume[s], solid.gml_id
        if vol < 0:
            self.fc.add("solid-orientation", solid.line, sid, f"Solid {sid or ''} is inside out: all faces point "
                        f"inwards (signed volume {vol:.3f} m³); reverse the vertex order of every face.")
        elif vol <= self.tol ** 3:
            self.fc.add("solid-closed", solid.line, sid, f"Solid {sid or ''} encloses no volume.")


def _tolerant_ids(points: np.ndarray, tol: float) -> list[int]:
    """Vertex ids where points within ``tol`` share an id (grid cells plus their 26 neighbours)."""
    cells: dict = defaultdict(list)
    ids, reps = [], []
    offsets = [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)]
    for p in points:
        c = tuple(np.floor(p / tol).astype(int))
        found = next((j for o in offsets for j in cells.get((c[0] + o[0], c[1] + o[1], c[2] + o[2]), ())
                      if np.abs(reps[j] - p).max() <= tol), None)
        if found is None:
            found = len(reps)
            reps.append(p)
            cells[c].append(found)
        ids.append(found)
    return ids


# -- small helpers --------------------------------------------------------------------------------
def _short(text: str) -> str:
    """Replace ``{namespace}name`` by ``prefix:name`` so messages read like the XML."""
    return _QNAME_IN_MSG.sub(lambda m: f"{PREFIXES.get(m.group(1), m.group(1))}:{m.group(2)}", text)


def _owner_id(node: etree._Element | None) -> str | None:
    while node is not None:
        gid = node.get(GML_ID)
        if gid:
            return gid
        node = node.getparent()
    return None


def _label(node: etree._Element) -> str:
    gid = node.get(GML_ID)
    return gid if gid else f"at line {node.sourceline}"


def _xyz(p: np.ndarray) -> str:
    return "(" + " ".join(f"{c:.3f}" for c in p) + ")"


@cache
def _qname(tag: str) -> str:
    """``prefix:name`` of an element tag (few distinct ones, so cached)."""
    return _short(tag)


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


def _srs_dimension(node: etree._Element, any_declared: bool) -> int | None:
    """srsDimension of the position element or its nearest ancestor that declares one."""
    while node is not None:
        value = node.get("srsDimension")
        if value is not None:
            return int(value) if value.isdigit() else None
        if not any_declared:
            return None
        node = node.getparent()
    return None


def _neutral_ids(tree: etree._Element) -> dict[str, str]:
    """Replace every gml:id by a short name reused from member to member; return new -> original.

    libxml2 (< 2.12) interns each xs:ID value it validates in a process-wide string dictionary whose
    hash table stops growing, so millions of distinct ids make validation quadratic. Uniqueness
    and syntax of the real ids are checked in ``_scan`` instead.
    """
    aliases = {}
    for n, node in enumerate(_attributed(tree)[0]):
        alias = f"i{n}"
        aliases[alias] = node.get(GML_ID)
        node.set(GML_ID, alias)
    return aliases


def _inherited(node: etree._Element | None, attribute: str) -> str | None:
    while node is not None:
        value = node.get(attribute)
        if value is not None:
            return value
        node = node.getparent()
    return None


def _move_into(node: etree._Element, parent: etree._Element, small: int = 256) -> None:
    """Move ``node`` (with its tail) to the end of ``parent``, in time linear in its size.

    lxml (4.9) re-links the namespaces of a moved subtree in time quadratic in its size when they
    are declared outside it, as here (on the CityModel): its namespace cache is keyed by the new
    namespace instead of the old one, so every node misses it and adds an entry. One appearance
    member with 600k texture associations then took many minutes. Nodes that already use the
    destination's namespace declarations do hit that cache, so a big subtree is moved in small
    pieces into a stash inside the destination first, then reassembled there. The nodes themselves
    are moved (not copied): their source lines, also those beyond 65535, stay right.
    """
    if not _is_big(node, small):
        parent.append(node)
        return
    stash = etree.SubElement(parent, "stash")
    _move_big(node, parent, stash, small)
    parent.remove(stash)


def _move_big(node: etree._Element, dest: etree._Element, stash: etree._Element, small: int) -> None:
    children = list(node)
    for child in children:
        if _is_big(child, small):
            _move_big(child, stash, stash, small)
        else:
            stash.append(child)
    dest.append(node)  # childless now, so cheap
    node.extend(children)  # already in the destination's namespaces: linear


def _is_big(node: etree._Element, small: int) -> bool:
    return len(node) > 0 and next(islice(node.iter(), small, None), None) is not None


def _remove_keep_tail(node: etree._Element) -> None:
    parent, tail = node.getparent(), node.tail or ""
    prev = node.getprevious()
    if prev is not None:
        prev.tail = (prev.tail or "") + tail
    else:
        parent.text = (parent.text or "") + tail
    parent.remove(node)


# -- reports --------------------------------------------------------------------------------------
_COLUMNS = ["file", "status", "details", "check", "severity", "line", "gml_id", "message"]


def write_report_csv(reports: Sequence[FileReport], path: str) -> None:
    """One row per issue (every file appears, a valid one with empty issue columns); UTF-8 with BOM for Excel."""
    with atomic_file(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8-sig") as out:
            writer = csv.writer(out)
            writer.writerow(_COLUMNS)
            for rep in reports:
                rows = rep.issues or [None]
                for issue in rows:
                    writer.writerow([rep.file, rep.status, rep.details] + (
                        [issue.check, issue.severity, issue.line if issue.line is not None else "",
                         issue.gml_id or "", issue.message] if issue else ["", "", "", "", ""]))


def write_report_html(reports: Sequence[FileReport], path: str) -> None:
    """A self-contained HTML page: the Table-13 style summary, then every issue."""
    esc = html.escape
    summary = "".join(
        f"<tr class='{'ok' if r.valid else 'fail'}'><td>{esc(Path(r.file).name)}</td><td>{r.status}</td>"
        f"<td>{esc(r.details)}</td><td>{r.size_bytes / 1e6:.2f}</td><td>{r.seconds:.2f}</td></tr>" for r in reports)
    issues = "".join(
        f"<tr class='{esc(i.severity)}'><td>{esc(Path(i.file).name)}</td><td>{esc(i.check)}</td>"
        f"<td>{esc(i.severity)}</td><td>{i.line if i.line is not None else ''}</td><td>{esc(i.gml_id or '')}</td>"
        f"<td>{esc(i.message)}</td></tr>" for r in reports for i in r.issues)
    n_ok = sum(r.valid for r in reports)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>CityGML 3.0 validation report</title>
<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse;margin-bottom:2em}}
td,th{{border:1px solid #bbb;padding:3px 8px;text-align:left;vertical-align:top}}th{{background:#eee}}
tr.fail td:nth-child(2),tr.error td:nth-child(3){{color:#b00;font-weight:bold}}
tr.ok td:nth-child(2){{color:#070;font-weight:bold}}tr.warning td:nth-child(3){{color:#a60}}</style></head>
<body><h1>CityGML 3.0 validation report</h1>
<p>{n_ok} of {len(reports)} file(s) valid.</p>
<h2>Summary</h2>
<table><tr><th>File</th><th>Status</th><th>Details</th><th>MB</th><th>Seconds</th></tr>{summary}</table>
<h2>Issues</h2>
<table><tr><th>File</th><th>Check</th><th>Severity</th><th>Line</th><th>gml:id</th><th>Message</th></tr>{issues}</table>
</body></html>
"""
    with atomic_file(path) as tmp:
        tmp.write_text(page, encoding="utf-8")
