"""Find and compile the CityGML 3.0 XML Schemas, so validation never needs the network.

Schemas come from a configured folder (an override, e.g. for an ADE), else the copy the plugin
ships in ``xsd/`` (see its NOTICE.md), else — only when that copy was removed from an install —
the plugin's cache, filled once by a download from schemas.opengis.net / www.w3.org. The download
mirrors the layout of the shared offline copy (``opengis/...``, ``w3/...``) and rewrites every
import to a relative path, so the cached copy validates offline exactly like the shared one
(libxml2 never sees an absolute URL).
"""
from __future__ import annotations

import functools
import posixpath
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

from lxml import etree

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import publish, staging_folder

ENTRY_POINT = "citygml3-all.xsd"
EMBEDDED_DIR = Path(__file__).resolve().parent / "xsd"
CACHE_SUBDIR = "citygml3-schemas"
DEFAULT_BASE_URL = "https://"
"""Prefix put before ``host/path`` of each public schema URL (a mirror or test server can replace it)."""

XSD_NS = "http://www.w3.org/2001/XMLSchema"
OGC = "http://schemas.opengis.net/"
W3C = "http://www.w3.org/"

# namespace -> public schema URL, imported by the entry point in this order (XLink and GML first).
CITYGML_MODULES: dict[str, str] = {
    "http://www.w3.org/1999/xlink": W3C + "1999/xlink.xsd",
    "http://www.opengis.net/gml/3.2": OGC + "gml/3.2.1/gml.xsd",
    "urn:oasis:names:tc:ciq:xal:3": OGC + "citygml/xAL/3.0/xAL.xsd",
    "http://www.opengis.net/citygml/3.0": OGC + "citygml/3.0/core.xsd",
    **{f"http://www.opengis.net/citygml/{name.lower()}/3.0": OGC + f"citygml/{name.lower()}/3.0/{name}.xsd"
       for name in ("appearance", "bridge", "building", "cityFurniture", "cityObjectGroup", "construction",
                    "dynamizer", "generics", "landUse", "pointCloud", "relief", "transportation", "tunnel",
                    "vegetation", "versioning", "waterBody")},
}

# Imports resolved by namespace rather than by their schemaLocation (published files differ in
# how they spell these locations; the namespace is what identifies the schema).
_KNOWN_IMPORTS: dict[str, str] = {
    **CITYGML_MODULES,
    "http://www.w3.org/XML/1998/namespace": W3C + "2001/xml.xsd",
    "urn:oasis:names:tc:ciq:ct:3": OGC + "citygml/xAL/3.0/CommonTypes.xsd",
    "http://www.isotc211.org/2005/gmd": OGC + "iso/19139/20070417/gmd/gmd.xsd",
    "http://www.isotc211.org/2005/gco": OGC + "iso/19139/20070417/gco/gco.xsd",
    "http://www.isotc211.org/2005/gsr": OGC + "iso/19139/20070417/gsr/gsr.xsd",
    "http://www.isotc211.org/2005/gss": OGC + "iso/19139/20070417/gss/gss.xsd",
    "http://www.isotc211.org/2005/gts": OGC + "iso/19139/20070417/gts/gts.xsd",
    "http://www.w3.org/2001/SMIL20/": OGC + "gml/3.1.1/smil/smil20.xsd",
    "http://www.w3.org/2001/SMIL20/Language": OGC + "gml/3.1.1/smil/smil20-language.xsd",
}


def find_schema_dir(configured: str | None, cache_dir: str, allow_download: bool,
                    base_url: str = DEFAULT_BASE_URL, feedback: Feedback = SILENT,
                    embedded: Path | None = EMBEDDED_DIR) -> tuple[Path, str]:
    """Return the folder holding ``citygml3-all.xsd`` and which source it came from.

    The source ("configured folder", "embedded", "cache", "downloaded") is returned so that the
    user is told which schemas a validation result rests on.
    """
    if configured:
        folder = Path(configured)
        if not (folder / ENTRY_POINT).is_file():
            raise InputError(f"The schema folder {folder} does not contain {ENTRY_POINT}. Point SCHEMA_DIR at a "
                             f"copy of the CityGML 3.0 schemas (e.g. shared/schemas) or leave it empty.")
        return folder, "configured folder"
    if embedded is not None and (embedded / ENTRY_POINT).is_file():
        return embedded, "embedded"
    cached = Path(cache_dir) / CACHE_SUBDIR
    if (cached / ENTRY_POINT).is_file():
        return cached, "cache"
    if not allow_download:
        raise InputError("No CityGML 3.0 schemas available: set SCHEMA_DIR to a folder containing "
                         f"{ENTRY_POINT} or allow a one-time download into {cached}.")
    download_schemas(cached, base_url=base_url, feedback=feedback)
    return cached, "downloaded"


def local_path(url: str) -> str:
    """Map a public schema URL onto the shared offline layout (``opengis/...``, ``w3/...``)."""
    parts = urllib.parse.urlsplit(url)
    path = posixpath.normpath(parts.path).lstrip("/")
    if parts.netloc == "www.w3.org":
        return "w3/" + path
    if parts.netloc != "schemas.opengis.net":
        raise InputError(f"Schema {url} is outside schemas.opengis.net and www.w3.org; cannot mirror it.")
    segs = path.split("/")
    if segs[0] == "citygml" and len(segs) == 4 and segs[2] == "3.0":  # citygml/<module>/3.0/<file>
        return "opengis/citygml/3.0/" + ("xAL/" if segs[1] == "xAL" else "") + segs[3]
    return "opengis/" + path


def download_schemas(target: Path, base_url: str = DEFAULT_BASE_URL, feedback: Feedback = SILENT,
                     timeout: float = 30.0) -> None:
    """Download every schema reachable from the CityGML 3.0 modules into ``target``.

    Imports and includes are followed (imports by namespace when known), written under the
    shared layout with relative ``schemaLocation``s, and the entry point is generated. The
    folder appears only when complete (downloaded into a staging folder beside it, then published).
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    with staging_folder(target.parent, ".wit-schemas-") as staging:
        tmp = staging / target.name
        queue = list(CITYGML_MODULES.values())
        done: set[str] = set()
        while queue:
            feedback.check_canceled()
            url = queue.pop(0)
            if url in done:
                continue
            done.add(url)
            feedback.info(f"Downloading {url}")
            doc = _fetch_xsd(url, base_url, timeout)
            here = posixpath.dirname(local_path(url))
            for node in doc.iter(f"{{{XSD_NS}}}import", f"{{{XSD_NS}}}include", f"{{{XSD_NS}}}redefine"):
                location = node.get("schemaLocation")
                dep = _KNOWN_IMPORTS.get(node.get("namespace", "")) if node.tag.endswith("import") else None
                if dep is None:
                    if not location:
                        continue
                    dep = urllib.parse.urljoin(url, location)
                node.set("schemaLocation", posixpath.relpath(local_path(dep), here))
                queue.append(dep)
            out = tmp / local_path(url)
            out.parent.mkdir(parents=True, exist_ok=True)
            # the root only: drops a DOCTYPE (W3C files) that a later parse might try to fetch
            out.write_bytes(etree.tostring(doc.getroot(), xml_declaration=True, encoding="UTF-8"))
            feedback.progress(min(95.0, len(done)))
        (tmp / ENTRY_POINT).write_text(_entry_point_xsd(), encoding="utf-8")
        publish(staging, target.parent)
    feedback.info(f"CityGML 3.0 schemas ({len(done)} files) saved in {target}")


def _fetch_xsd(url: str, base_url: str, timeout: float) -> etree._ElementTree:
    parts = urllib.parse.urlsplit(url)
    fetch = base_url + parts.netloc + parts.path
    if urllib.parse.urlsplit(fetch).scheme not in ("http", "https"):
        raise InputError(f"{fetch}: the schemas are downloaded over http(s) only.")
    try:
        with urllib.request.urlopen(fetch, timeout=timeout) as response:  # nosec B310  # http(s), checked above
            data = response.read()
    except (urllib.error.URLError, OSError) as exc:
        raise InputError(f"Could not download the CityGML schema {fetch} ({exc}). Check the internet connection "
                         f"or set SCHEMA_DIR to a local copy of the schemas.") from exc
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    try:
        return etree.ElementTree(etree.fromstring(data, parser))
    except etree.XMLSyntaxError as exc:
        raise InputError(f"{fetch} is not an XML schema ({exc}); is the server returning an error page?") from exc


def _entry_point_xsd() -> str:
    imports = "\n".join(f'  <xs:import namespace="{ns}" schemaLocation="{local_path(url)}"/>'
                        for ns, url in CITYGML_MODULES.items())
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            "<!-- Validation entry point for CityGML 3.0 documents mixing any modules (written by WIT City Model). "
            "-->\n"
            f'<xs:schema xmlns:xs="{XSD_NS}" elementFormDefault="qualified" version="3.0.0">\n{imports}\n'
            "</xs:schema>\n")


def load_schema(schema_dir: Path) -> etree.XMLSchema:
    """The compiled ``citygml3-all.xsd`` of ``schema_dir`` (~0.1-0.5 s), compiled for each use: a schema
    kept for the process breaks once something calls libxml2's ``xmlCleanupParser`` (SpatiaLite does, in
    QGIS), see ``validation.xsd._compiled``."""
    entry = Path(schema_dir).resolve() / ENTRY_POINT
    folder = entry.parent
    if not entry.is_file():
        raise InputError(f"{entry} not found: set SCHEMA_DIR to a folder containing the CityGML 3.0 schemas.")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    try:
        return etree.XMLSchema(etree.parse(str(entry), parser))
    except (etree.XMLSchemaParseError, etree.XMLSyntaxError) as exc:
        raise InputError(f"The schemas in {folder} cannot be compiled ({exc}); the folder is incomplete or "
                         f"damaged — delete it to download again or point SCHEMA_DIR to a good copy.") from exc


def schema_namespaces(schema_dir: Path) -> frozenset[str]:
    """Target namespaces of all schema files in the folder: anything else in a document is an ADE."""
    return _namespaces(str(Path(schema_dir).resolve()))


@functools.lru_cache(maxsize=4)
def _namespaces(folder: str) -> frozenset[str]:
    found = {"http://www.w3.org/2001/XMLSchema-instance", "http://www.w3.org/XML/1998/namespace"}
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    for xsd in Path(folder).rglob("*.xsd"):
        try:
            ns = etree.parse(str(xsd), parser).getroot().get("targetNamespace")
        except etree.XMLSyntaxError:
            continue
        if ns:
            found.add(ns)
    return frozenset(found)


class ContentModel:
    """Required child elements per element, read from the XSDs.

    libxml2 answers a missing required element with "<next element>: This element is not
    expected" and a truncated list of candidates; this model lets the report name the element
    that is actually missing (e.g. ``dem:lod`` in a ``dem:TINRelief``).
    """

    def __init__(self, folder: Path):
        self._elements: dict[str, etree._Element] = {}
        self._types: dict[str, etree._Element] = {}
        self._members: dict[str, set[str]] = {}  # substitution group head -> direct members
        self.local_names: set[str] = set()  # every element name declared anywhere
        parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, remove_comments=True)
        for xsd in sorted(Path(folder).rglob("*.xsd")):
            try:
                root = etree.parse(str(xsd), parser).getroot()
            except etree.XMLSyntaxError:
                continue
            tns = root.get("targetNamespace", "")
            for node in root:
                name = node.get("name")
                if name and node.tag == f"{{{XSD_NS}}}element":
                    self._elements[f"{{{tns}}}{name}"] = node
                    head = node.get("substitutionGroup")
                    if head:
                        self._members.setdefault(self._qname(node, head), set()).add(f"{{{tns}}}{name}")
                elif name and node.tag == f"{{{XSD_NS}}}complexType":
                    self._types[f"{{{tns}}}{name}"] = node
            self.local_names.update(f"{{{tns}}}{e.get('name')}" for e in root.iter(f"{{{XSD_NS}}}element")
                                    if e.get("name"))

    @staticmethod
    def _qname(node: etree._Element, value: str) -> str:
        prefix, _, local = value.rpartition(":")
        return f"{{{node.nsmap.get(prefix or None, '')}}}{local}"

    def _substitutes(self, head: str) -> set[str]:
        out, todo = {head}, [head]
        while todo:
            for member in self._members.get(todo.pop(), ()):
                if member not in out:
                    out.add(member)
                    todo.append(member)
        return out

    def _required_particles(self, ctype: etree._Element | None, tns: str, depth: int = 0) -> list[str]:
        if ctype is None or depth > 40:
            return []
        out: list[str] = []
        for deriv in ctype.iterfind(f"{{{XSD_NS}}}complexContent/*"):
            if deriv.tag == f"{{{XSD_NS}}}extension":
                base = self._types.get(self._qname(deriv, deriv.get("base", "")))
                out += self._required_particles(base, _tns_of(base), depth + 1)
            out += self._sequence_particles(deriv, tns)
        return out + self._sequence_particles(ctype, tns)

    def _sequence_particles(self, parent: etree._Element, tns: str) -> list[str]:
        out: list[str] = []
        for seq in parent.iterfind(f"{{{XSD_NS}}}sequence"):
            out += self._particles_of(seq, tns)
        return out

    def _particles_of(self, seq: etree._Element, tns: str) -> list[str]:
        """Required elements of one sequence (choices and optional parts never count as required)."""
        if seq.get("minOccurs") == "0":
            return []
        out: list[str] = []
        for part in seq:
            if part.get("minOccurs") == "0":
                continue
            if part.tag == f"{{{XSD_NS}}}element":
                out.append(self._qname(part, part.get("ref")) if part.get("ref") else f"{{{tns}}}{part.get('name')}")
            elif part.tag == f"{{{XSD_NS}}}sequence":
                out += self._particles_of(part, tns)
        return out

    def missing_required(self, parent_tag: str, child_tags: list[str]) -> list[str]:
        """Required children of a ``parent_tag`` element that none of ``child_tags`` provides."""
        decl = self._elements.get(parent_tag)
        if decl is None:
            return []
        if decl.get("type"):
            ctype = self._types.get(self._qname(decl, decl.get("type")))
        else:
            ctype = decl.find(f"{{{XSD_NS}}}complexType")
        present = set(child_tags)
        return [p for p in self._required_particles(ctype, _tns_of(ctype))
                if not (self._substitutes(p) & present)]


def _tns_of(node: etree._Element | None) -> str:
    return node.getroottree().getroot().get("targetNamespace", "") if node is not None else ""


@functools.lru_cache(maxsize=4)
def content_model(schema_dir: str) -> ContentModel:
    """The cached ``ContentModel`` of a schema folder (built on the first invalid document)."""
    return ContentModel(Path(schema_dir))
