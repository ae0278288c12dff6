"""XSD validation by libxml2's own streaming validator, beside the other checks.

``xmllint --stream`` validates a file at C speed in constant memory; lxml cannot do the same with
line numbers (its validating parser reports every error on line 0, and validating a parsed tree
needs the tree in memory). So the same libxml2 function that streams a file through the schema
(``xmlSchemaValidateFile``) is called through ctypes, in a thread: ctypes releases the GIL, so it
runs on another core while the other checks parse the file with lxml. Every error comes with the
line where libxml2 met it.

Where libxml2 cannot be loaded through ctypes, lxml's validating parser does the XSD check inside
the checks' own parse: the same errors, without line numbers (``Fallback``).

Messages are then made readable (``describe``): ``prefix:name`` instead of ``{namespace}name``,
the missing required element named, a close match suggested for an unknown element, elements of an
ADE whose schema is missing reported once. That needs the elements around each error, so a file
with schema errors is parsed once more, keeping only the elements at those lines (each reported on
its start line, as ``xmllint`` without ``--stream`` does).
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
import re
import threading
from dataclasses import dataclass
from difflib import get_close_matches
from pathlib import Path

from lxml import etree

from ..reader import PARSE_OPTIONS, Stream, SyntaxProblem
from ..schemas import ENTRY_POINT, content_model
from .names import IssueList, owner_id, remove_keep_tail, short

_ELEMENT_IN_MSG = re.compile(r"^Element '([^']+)'")
_BAD_ID = re.compile(r"^Element '[^']+', attribute '\{http://www\.opengis\.net/gml/3\.2\}id': '([^']*)' is not a valid "
                     r"value of the atomic type 'xs:ID'")
_SCHEMA_VALIDITY = 17  # XML_FROM_SCHEMASV: errors of the validator (the parser's own are reported by the checks)
_MAX_KEPT = 100_000  # errors kept per file (they are counted beyond)


@dataclass
class SchemaError:
    line: int | None
    message: str


class _XmlError(ctypes.Structure):
    _fields_ = [("domain", ctypes.c_int), ("code", ctypes.c_int), ("message", ctypes.c_char_p),
                ("level", ctypes.c_int), ("file", ctypes.c_char_p), ("line", ctypes.c_int),
                ("str1", ctypes.c_char_p), ("str2", ctypes.c_char_p), ("str3", ctypes.c_char_p),
                ("int1", ctypes.c_int), ("int2", ctypes.c_int), ("ctxt", ctypes.c_void_p), ("node", ctypes.c_void_p)]


_ERROR_HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.POINTER(_XmlError))
_GENERIC_HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p)
_QUIET = _ERROR_HANDLER(lambda _data, _error: None)
_QUIET_GENERIC = _GENERIC_HANDLER(lambda _data, _message: None)
_SIGNATURES = {
    "xmlInitParser": (None, []),
    "xmlSchemaNewParserCtxt": (ctypes.c_void_p, [ctypes.c_char_p]),
    "xmlSchemaSetParserStructuredErrors": (None, [ctypes.c_void_p, _ERROR_HANDLER, ctypes.c_void_p]),
    "xmlSchemaParse": (ctypes.c_void_p, [ctypes.c_void_p]),
    "xmlSchemaFreeParserCtxt": (None, [ctypes.c_void_p]),
    "xmlSchemaNewValidCtxt": (ctypes.c_void_p, [ctypes.c_void_p]),
    "xmlSchemaSetValidStructuredErrors": (None, [ctypes.c_void_p, _ERROR_HANDLER, ctypes.c_void_p]),
    "xmlSchemaValidateFile": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]),
    "xmlSchemaFreeValidCtxt": (None, [ctypes.c_void_p]),
    "xmlSchemaFree": (None, [ctypes.c_void_p]),
    "xmlSetStructuredErrorFunc": (None, [ctypes.c_void_p, _ERROR_HANDLER]),
    "xmlSetGenericErrorFunc": (None, [ctypes.c_void_p, _GENERIC_HANDLER]),
}


@functools.lru_cache(maxsize=1)
def _libxml2() -> ctypes.CDLL | None:
    """The libxml2 that lxml uses (or any on the library path), with the functions above; None if none."""
    for candidate in _candidates():
        try:
            lib = ctypes.CDLL(candidate)
        except OSError:
            continue
        if all(hasattr(lib, name) for name in _SIGNATURES):
            for name, (restype, argtypes) in _SIGNATURES.items():
                getattr(lib, name).restype, getattr(lib, name).argtypes = restype, argtypes
            lib.xmlInitParser()
            return lib
    return None


def _candidates():
    """lxml's own module first (on Linux and macOS its symbols include the libxml2 it links), then libxml2 by name."""
    yield etree.__file__
    for name in ("xml2", "libxml2", "libxml2-2"):
        try:
            found = ctypes.util.find_library(name)
        except OSError:  # find_library can trip over what the linker prints
            found = None
        if found:
            yield found


def streaming_available(schema_dir: Path) -> bool:
    """Whether libxml2 can be loaded for the streaming validator and ``schema_dir`` has the entry point."""
    return _libxml2() is not None and (Path(schema_dir) / ENTRY_POINT).is_file()


def _compiled(folder: str) -> int | None:
    """libxml2's compiled schema of ``folder``, or None (no libxml2, no schema); free it with ``xmlSchemaFree``.

    Compiled for each file and freed when its validation ends, never kept for the process: whatever in
    the process calls libxml2's ``xmlCleanupParser`` (SpatiaLite does, each time GDAL or QGIS closes a
    SpatiaLite connection) frees the built-in types a compiled schema points to, and a schema kept from
    before then reports "Internal error" for every element or crashes QGIS (seen with libxml2 2.15,
    QGIS 3.44).
    """
    lib = _libxml2()
    if lib is None or not (Path(folder) / ENTRY_POINT).is_file():
        return None
    lib.xmlInitParser()  # again: a cleanup may have happened since
    parser = lib.xmlSchemaNewParserCtxt(os.fsencode(Path(folder) / ENTRY_POINT))
    if not parser:
        return None
    lib.xmlSchemaSetParserStructuredErrors(parser, _QUIET, None)  # "skipping import" notices
    schema = lib.xmlSchemaParse(parser)
    lib.xmlSchemaFreeParserCtxt(parser)
    return schema or None


class StreamingValidation:
    """libxml2's streaming XSD validation of one file, in a background thread (``start``, then ``errors``),
    with its own compiled schema, freed when the thread ends (a cancelled run leaves the thread to finish)."""

    def __init__(self, path: Path, schema_dir: Path, enabled: bool = True):
        self.path = path
        self.schema = _compiled(str(Path(schema_dir).resolve())) if enabled else None
        self.found: list[SchemaError] = []
        self.more = 0  # errors beyond _MAX_KEPT
        self.code: int | None = None
        self._handler = _ERROR_HANDLER(self._on_error)  # referenced here while libxml2 may call it
        self._thread = threading.Thread(target=self._run, name="wit-xsd", daemon=True)

    @property
    def available(self) -> bool:
        return self.schema is not None

    def start(self) -> None:
        self._thread.start()

    def errors(self) -> list[SchemaError]:
        """Wait for the validation; its errors in file order (``code`` < 0: libxml2 could not finish the file)."""
        self._thread.join()
        return self.found

    def _run(self) -> None:
        lib = _libxml2()
        if lib is None:  # (never: the schema was compiled by it)
            return
        lib.xmlSetStructuredErrorFunc(None, _QUIET)  # this thread's parser errors: the checks report them
        lib.xmlSetGenericErrorFunc(None, _QUIET_GENERIC)
        ctxt = lib.xmlSchemaNewValidCtxt(self.schema)
        lib.xmlSchemaSetValidStructuredErrors(ctxt, self._handler, None)
        path = str(self.path).encode("utf-8") if os.name == "nt" else os.fsencode(self.path)
        try:
            self.code = lib.xmlSchemaValidateFile(ctxt, path, 0)
        finally:
            lib.xmlSchemaFreeValidCtxt(ctxt)
            lib.xmlSchemaFree(self.schema)

    def _on_error(self, _data, error) -> None:
        e = error.contents
        if e.domain != _SCHEMA_VALIDITY or e.level < 2:
            return
        if len(self.found) < _MAX_KEPT:
            self.found.append(SchemaError(e.line or None, (e.message or b"").decode("utf-8", "replace").strip()))
        else:
            self.more += 1


def whole_document_errors(path: Path, schema: etree.XMLSchema) -> list[SchemaError]:
    """Errors of a file with a DOCTYPE, whose entity references stop libxml2's streaming validator.

    Such files are rare and small (CityGML needs no DOCTYPE): the tree is validated in memory with
    the entity references left out (reported by the checks), as if their text were absent.
    """
    try:
        tree = etree.parse(str(path), etree.XMLParser(**PARSE_OPTIONS))
    except etree.XMLSyntaxError:
        return []  # reported by the checks
    for entity in list(tree.iter(etree.Entity)):
        remove_keep_tail(entity)
    if schema.validate(tree):
        return []
    return [SchemaError(e.line or None, e.message.strip()) for e in schema.error_log]


def fallback_errors(stream: Stream) -> list[SchemaError]:
    """The errors of lxml's validating parse (``Stream(schema=...)``): no line numbers."""
    return [SchemaError(None, e.message.strip()) for e in stream.schema_errors]


def describe(errors: list[SchemaError], issues: IssueList, path: Path, root_tag: str, schema_dir: Path,
             known_ns: frozenset[str]) -> None:
    """Turn schema errors into issues: readable messages, the gml:id they concern, ADEs once."""
    wanted: list[tuple[SchemaError, str]] = []
    ades: set[str] = set()
    previous: SchemaError | None = None
    for err in errors:
        repeated = (previous is not None and "list type" in err.message and previous.line == err.line
                    and _tag_of(previous.message) == _tag_of(err.message))
        previous = err
        if repeated:
            continue  # libxml2 repeats a bad list item as a bad list: report it once
        tag = _tag_of(err.message)
        ns = tag[1:].split("}")[0] if tag.startswith("{") else ""
        if ns and ns not in known_ns:
            if ns not in ades:
                ades.add(ns)
                issues.add("ade", err.line, None, f"Uses ADE namespace {ns} whose schema is not available, so its "
                           f"elements (first: {tag.split('}')[1]}) cannot be validated. Add the ADE's XSD to the "
                           "schema folder (and import it in citygml3-all.xsd) or remove the ADE content.")
            continue
        wanted.append((err, tag))
    if any(err.line for err, tag in wanted[:issues.cap] if tag):
        context = _Context([(err, tag) for err, tag in wanted[:issues.cap] if err.line and tag])
        stream = Stream(path, root_tag, on_chunk=lambda _pos: None)
        try:
            for parent, n in stream.parts():
                context.part(parent, n, stream.root)
        except SyntaxProblem:
            pass  # the elements before it were seen; the checks report the problem
        found = context.finish()
    else:
        found = {}
    model = None
    for err, tag in wanted:
        node_info = found.get(id(err))
        if node_info is None or issues.full("xsd"):
            issues.add("xsd", err.line, None, short(err.message))
            continue
        line, gml_id, parent_tag, sibling_tags = node_info
        bad_id = _BAD_ID.match(err.message)
        if bad_id:
            issues.add("xsd", line, bad_id.group(1), f"gml:id '{bad_id.group(1)}' is not a valid XML name (it must "
                       "start with a letter or '_' and contain no spaces or ':').")
            continue
        text = short(err.message)
        if "This element is not expected" in err.message and parent_tag:
            model = model or content_model(str(Path(schema_dir).resolve()))
            missing = model.missing_required(parent_tag, sibling_tags)
            expected = re.findall(r"\{[^}]*\}[\w.\-]+", err.message.split("Expected is", 1)[-1])
            if missing:
                text = (f"{short(parent_tag)} is missing the required element {short(missing[0])} "
                        f"(found {short(tag)} where {short(missing[0])} was expected).")
            elif tag not in model.local_names:
                guess = get_close_matches(short(tag), [short(e) for e in expected], n=1)
                text = (f"Unknown element {short(tag)} in {short(parent_tag)} (no schema defines it)"
                        + (f"; did you mean {guess[0]}?" if guess else ".")
                        + (f" Expected one of: {', '.join(short(e) for e in expected)}." if expected else ""))
        issues.add("xsd", line, gml_id, text)


class _Context:
    """Finds, part by part, the element of each error: the last one of its name starting at or before its line.

    libxml2 reports an error when it meets it: a bad attribute on the start tag's line, a bad value
    or a missing child on the end tag's line. Parts come in file order, so the candidate current
    when a later element of that name starts past the error's line is the element.
    """

    def __init__(self, wanted: list[tuple[SchemaError, str]]):
        self.by_tag: dict[str, _Candidates] = {}
        for err, tag in sorted(wanted, key=lambda w: w[0].line or 0):  # (all have a line)
            self.by_tag.setdefault(tag, _Candidates()).errors.append(err)
        self.found: dict[int, tuple | None] = {}
        self.seen_tags: dict[etree._Element, set[str]] = {}  # children of big elements handed out earlier

    def part(self, parent: etree._Element, n: int, root: etree._Element) -> None:
        children = parent[:n]
        if parent is not root:
            self.seen_tags.setdefault(parent, set()).update(c.tag for c in children if isinstance(c.tag, str))
        for tag, cands in self.by_tag.items():
            for child in children:
                for node in child.iter(tag):
                    cands.meet(node, self)
            cands.settle(self)

    def finish(self) -> dict[int, tuple | None]:
        for cands in self.by_tag.values():
            cands.settle(self)
            for err in cands.errors[cands.next:]:
                self.found[id(err)] = cands.described
        return self.found

    def describe(self, node: etree._Element) -> tuple[int | None, str | None, str | None, list[str]]:
        parent = node.getparent()
        if parent is None:
            return node.sourceline, owner_id(node), None, []
        siblings = [c.tag for c in parent if isinstance(c.tag, str)] + sorted(self.seen_tags.get(parent, ()))
        return node.sourceline, owner_id(node), parent.tag, siblings


class _Candidates:
    """The errors about one element name, in line order, and the element that is the candidate for the next."""

    def __init__(self) -> None:
        self.errors: list[SchemaError] = []
        self.next = 0  # first error not yet given its element
        self.node: etree._Element | None = None  # current candidate, still in the tree
        self.described: tuple | None = None  # current candidate, described before its part was freed

    def meet(self, node: etree._Element, context: _Context) -> None:
        line = node.sourceline or 0
        while self.next < len(self.errors) and (self.errors[self.next].line or 0) < line:  # (all have a line)
            self.settle(context)
            context.found[id(self.errors[self.next])] = self.described
            self.next += 1
        self.node = node

    def settle(self, context: _Context) -> None:
        """Describe the candidate while its part is alive."""
        if self.node is not None:
            self.described, self.node = context.describe(self.node), None


def _tag_of(message: str) -> str:
    match = _ELEMENT_IN_MSG.match(message)
    return match.group(1) if match else ""
