"""Element names and the issue records shared by the validation modules (namespaces: ``citygml.namespaces``)."""
from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field
from functools import cache

from lxml import etree

from ..namespaces import GML_ID, PREFIXES, URIS

GML, XLINK, CORE, APP = (URIS[prefix] for prefix in ("gml", "xlink", "core", "app"))
NAMESPACES = {prefix: URIS[prefix] for prefix in ("gml", "app", "xlink", "core")}  # for XPath
G = {name: f"{{{GML}}}{name}" for name in (
    "Solid", "Shell", "exterior", "interior", "surfaceMember", "Polygon", "PolygonPatch", "LinearRing", "posList",
    "pos", "lowerCorner", "upperCorner", "Triangle", "CompositeSurface", "OrientableSurface", "baseSurface",
    "Surface", "patches", "MultiSurface", "boundedBy", "Envelope", "CoordinateSystemAxis")}
A = {name: f"{{{APP}}}{name}" for name in (
    "imageURI", "TexCoordList", "textureCoordinates", "ring", "target")}
POSITIONS = (G["posList"], G["pos"], G["lowerCorner"], G["upperCorner"])
_QNAME_IN_MSG = re.compile(r"\{([^}]*)\}([\w.\-]+)")


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


class IssueList:
    """The issues of one file, at most ``cap`` per check and severity (the rest are counted)."""

    def __init__(self, file: str, cap: int):
        self.file, self.cap = file, cap
        self.issues: list[Issue] = []
        self.counts: Counter = Counter()

    def add(self, check: str, line: int | None, gml_id: str | None, message: str, severity: str = "error") -> None:
        self.counts[check, severity] += 1
        if self.counts[check, severity] <= self.cap:
            self.issues.append(Issue(self.file, check, severity, line, gml_id, message))

    def full(self, check: str, severity: str = "error") -> bool:
        """True when further issues of this kind would only be counted."""
        return self.counts[check, severity] >= self.cap

    def closed(self) -> list[Issue]:
        """The issues, then one line per check whose issues were not all listed."""
        for (check, severity), number in self.counts.items():
            if number > self.cap:
                self.issues.append(Issue(self.file, check, severity, None, None,
                                         f"... and {number - self.cap} more {check} {severity}s not listed."))
        return self.issues


def short(text: str) -> str:
    """Replace ``{namespace}name`` by ``prefix:name`` so messages read like the XML."""
    return _QNAME_IN_MSG.sub(lambda m: f"{PREFIXES.get(m.group(1), m.group(1))}:{m.group(2)}", text)


@cache
def qname(tag: str) -> str:
    """``prefix:name`` of an element tag (few distinct ones, so cached)."""
    return short(tag)


def owner_id(node: etree._Element | None) -> str | None:
    """The gml:id of ``node`` or of its nearest ancestor that has one."""
    while node is not None:
        gid = node.get(GML_ID)
        if gid:
            return gid
        node = node.getparent()
    return None


def label(node: etree._Element) -> str:
    """How a message names an object: its gml:id, else its line."""
    gid = node.get(GML_ID)
    return gid if gid else f"at line {node.sourceline}"


def remove_keep_tail(node: etree._Element) -> None:
    """Remove ``node`` (an entity reference) but keep the text after it."""
    parent, tail = node.getparent(), node.tail or ""
    prev = node.getprevious()
    if prev is not None:
        prev.tail = (prev.tail or "") + tail
    else:
        parent.text = (parent.text or "") + tail
    parent.remove(node)
