"""Offline CityGML 3.0 validation: XSD validity plus the checks an XSD cannot express.

Why a custom validator: XSD validation says nothing about geometry (closed, outward-oriented,
planar, simple solids; degenerate TIN triangles), about ``#id`` references or texture files.
Each file is read in two streams at once, in constant memory (see ``validation/``):

* libxml2's own streaming validator, the engine of ``xmllint --stream``, checks it against the
  XSDs in a background thread (``validation.xsd``);
* one lxml parse hands the other checks the finished parts of the file, a few MB at a time, and
  they pull out ids, coordinates and references in bulk and check them in numpy
  (``validation.checks``, ``validation.geometry``), in local metres whatever the CRS
  (``validation.crs``).

Files that are empty, not XML, not CityGML 3.0 or cut short get one message saying so. Parsing
never expands entities, loads DTDs or touches the network (XXE-safe).
"""
from __future__ import annotations

import csv
import gc
import html
import time
from collections.abc import Sequence
from pathlib import Path

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import atomic_file
from . import reader as streaming
from .namespaces import CITYGML3_NAMESPACES
from .schemas import load_schema, schema_namespaces
from .validation.checks import FileCheck
from .validation.names import FileReport, Issue, IssueList, qname
from .validation.xsd import (
    StreamingValidation,
    describe,
    fallback_errors,
    streaming_available,
    whole_document_errors,
)

__all__ = ["FileReport", "Issue", "validate_files", "write_report_csv", "write_report_html"]

_OTHER_CITYGML = {"http://www.opengis.net/citygml/1.0": "1.0", "http://www.opengis.net/citygml/2.0": "2.0"}
_NOT_XML_HINTS = {b"\x1f\x8b": "a gzip-compressed file; decompress it first", b"PK\x03\x04": "a ZIP archive; "
                  "extract the .gml first", b"{": "JSON (CityJSON?), not CityGML"}


def validate_files(paths: Sequence[str], schema_dir: Path, feedback: Feedback = SILENT,
                   planarity_tol: float = 0.01, vertex_tol: float = 0.001, min_triangle_area: float = 1e-6,
                   max_issues_per_check: int = 200) -> list[FileReport]:
    """Validate CityGML 3.0 files against the XSDs in ``schema_dir`` and the geometry/reference rules.

    ``planarity_tol`` (m): largest distance of a face vertex from the face's plane;
    ``vertex_tol`` (m): coordinates closer than this are the same vertex when matching shell edges;
    ``min_triangle_area`` (m²): TIN triangles at or below it are degenerate;
    (all in metres whatever the CRS: geographic coordinates are measured in local metres);
    ``max_issues_per_check``: issues listed per check and file (the rest are counted), so a badly
    broken 1 GB file still gives a readable report.
    """
    if not paths:
        raise InputError("No CityGML files given: choose at least one .gml file to validate.")
    files = [Path(p) for p in paths]
    for path in files:
        _check_readable(path)
    if not streaming_available(schema_dir):
        load_schema(schema_dir)  # lxml's compile names what is wrong with the folder (or serves the fallback)
    known = schema_namespaces(schema_dir)
    total = sum(p.stat().st_size for p in files) or 1
    done = 0
    reports = []
    for path in files:
        feedback.check_canceled()
        feedback.info(f"Validating {path.name}")
        size = path.stat().st_size

        def on_chunk(position: int, before: int = done) -> None:
            feedback.check_canceled()
            feedback.progress(100.0 * (before + position) / total)

        start = time.perf_counter()
        issues = _FileValidation(path, Path(schema_dir), known, planarity_tol, vertex_tol, min_triangle_area,
                                 max_issues_per_check, on_chunk).run()
        report = FileReport(str(path), not any(i.severity == "error" for i in issues), issues, size,
                            time.perf_counter() - start)
        feedback.info(f"{path.name}: {report.status} ({report.details})")
        reports.append(report)
        done += size
        feedback.progress(100.0 * done / total)
    return reports


def _check_readable(path: Path) -> None:
    """An input that cannot be read at all stops the run up front (the others are judged in the report)."""
    if not path.is_file():
        raise InputError(f"CityGML file {path} does not exist or is not a file.")
    try:
        with open(path, "rb") as stream:
            stream.read(1)
    except OSError as exc:
        raise InputError(f"CityGML file {path} cannot be read: {exc.strerror or exc}.") from exc


class _FileValidation:
    """One file: its kind first (empty, not XML, not CityGML 3.0), then the XSD and all other checks."""

    def __init__(self, path: Path, schema_dir: Path, known_ns: frozenset[str], planarity_tol: float,
                 vertex_tol: float, min_triangle_area: float, max_issues: int, on_chunk):
        self.path, self.schema_dir, self.known_ns = path, schema_dir, known_ns
        self.tolerances = (planarity_tol, vertex_tol, min_triangle_area)
        self.max_issues, self.on_chunk = max_issues, on_chunk
        self.syntax, self.schema_issues, self.other = (IssueList(str(path), max_issues) for _ in range(3))
        self.bulk = False
        self.nsmap: dict[str | None, str] = {}

    def run(self) -> list[Issue]:
        root = self._first_look()
        if isinstance(root, Issue):
            return [root]
        docinfo = root.getroottree().docinfo
        has_doctype = bool(docinfo.internalDTD is not None or docinfo.doctype)
        xsd = StreamingValidation(self.path, self.schema_dir, enabled=not has_doctype)
        stream = streaming.Stream(self.path, root.tag, self.on_chunk,
                                  schema=None if xsd.available or has_doctype else load_schema(self.schema_dir))
        if xsd.available:
            xsd.start()
        # the regular bulk read from the bytes (validation.bulk): only while the XSD thread reads the file itself
        self.bulk = xsd.available and not has_doctype
        self.nsmap = root.nsmap
        cut = self._checks(stream)
        if has_doctype:
            errors = whole_document_errors(self.path, load_schema(self.schema_dir))
        else:
            errors = xsd.errors() if xsd.available else fallback_errors(stream)
        if xsd.available and xsd.code is not None and xsd.code < 0 and not self.syntax.issues:
            self.schema_issues.add("xsd", None, None, f"XSD validation could not finish this file (libxml2 error "
                                   f"{xsd.code}).")
        if cut is not None:  # what the schema says about the cut-off end only repeats that it is cut off
            errors = [e for e in errors if e.line is None or e.line < cut]
        if errors:
            describe(errors, self.schema_issues, self.path, root.tag, self.schema_dir, self.known_ns)
            if not xsd.available and not has_doctype:
                self.schema_issues.add("xsd", None, None, "Line numbers of schema errors are not available: libxml2 "
                                       "could not be loaded for its streaming validator.", "warning")
        return self.syntax.closed() + self.schema_issues.closed() + self.other.closed()

    def _first_look(self):
        """The root element, or the one issue saying why the file is no CityGML 3.0 document at all."""
        name = str(self.path)
        problem = _not_xml(self.path)
        if problem:
            return Issue(name, "xml", "error", None, None, problem)
        try:
            root = streaming.first_element(self.path)
        except streaming.SyntaxProblem as exc:
            return Issue(name, "xml", "error", exc.line, None, f"The file is not well-formed XML at its start "
                         f"({exc.message}); nothing could be checked.")
        problem = _not_citygml3(root.tag)
        return Issue(name, "xml", "error", root.sourceline, None, problem) if problem else root

    def _checks(self, stream: streaming.Stream) -> int | None:
        """Every check but the XSD, part by part; the line where a truncated file ends, if it is."""
        checks = FileCheck(self.path, self.other, stream.raw, *self.tolerances)
        if self.bulk:
            checks.bulk.disable_for(self.nsmap)
            stream.thin = checks.bulk.thin
        collecting = gc.isenabled()
        gc.disable()  # the pass makes millions of short-lived objects and no cycles: collections would only cost time
        try:
            for parent, n in stream.parts():
                if checks.root is None:
                    checks.start(stream.root)
                checks.part(parent, n)
            checks.finish()
        except streaming.SyntaxProblem as exc:
            if exc.at_end:
                self.syntax.add("xml", exc.line, None, f"The file is truncated: it ends at line {exc.line} inside "
                                f"{_open_element(stream.root)}, before the XML is complete. Everything before was "
                                "checked.")
                return exc.line
            self.syntax.add("xml", exc.line, None, f"Not well-formed XML: {exc.message}. Nothing after this point was "
                            "checked.")
        finally:  # on cancel the schema thread is left to finish alone (libxml2 cannot be interrupted)
            if collecting:
                gc.enable()
        return None


def _not_xml(path: Path) -> str | None:
    """Why the file is not XML at all (empty, white space only, binary, JSON), or None."""
    text, problem = file_start(path, "XML")
    if problem:
        return problem
    start = text.lstrip()[:4]
    if start.startswith(b"<") or not start:
        return None
    hint = next((h for magic, h in _NOT_XML_HINTS.items() if start.startswith(magic)), None)
    shown = start[:4].decode("latin-1").encode("unicode_escape").decode()
    return f"The file is not XML: it starts with '{shown}'" + (f" ({hint})." if hint else ", not with '<'.")


def file_start(path: Path, kind: str) -> tuple[bytes, str | None]:
    """The file's first 4 kB (without a UTF-8 byte order mark), or why there is nothing in it: empty, or only white
    space (no ``kind``)."""
    if path.stat().st_size == 0:
        return b"", "The file is empty (0 bytes): there is nothing to validate."
    with open(path, "rb") as stream:
        head = stream.read(4096)
    text = head[3:] if head.startswith(b"\xef\xbb\xbf") else head
    if not text.strip() and path.stat().st_size <= len(head):
        return text, f"The file contains only white space, no {kind}."
    return text, None


def _not_citygml3(root_tag: str) -> str | None:
    """Why a well-formed file is not a CityGML 3.0 document (its root element), or None."""
    ns, _, local = root_tag[1:].partition("}") if root_tag.startswith("{") else ("", "", root_tag)
    if ns in CITYGML3_NAMESPACES:
        return None
    if ns in _OTHER_CITYGML:
        return (f"The file is CityGML {_OTHER_CITYGML[ns]} (root element {local} in {ns}), not CityGML 3.0: "
                "convert it to CityGML 3.0 first (e.g. citygml-tools upgrade).")
    return (f"The file is XML but not CityGML 3.0: its root element is {local}"
            + (f" in namespace {ns}" if ns else " (no namespace)") + "; a CityGML 3.0 file starts with "
            "core:CityModel (http://www.opengis.net/citygml/3.0).")


def _open_element(root) -> str:
    """The innermost element still open where a truncated file ends, as ``prefix:name (line n)``."""
    node = root
    while node is not None and len(node):
        node = node[-1]
    while node is not None and node.getparent() is not None and node.getnext() is None and not len(node) \
            and node.tail is not None:
        node = node.getparent()  # a finished last child: its parent is the open one
    return f"{qname(node.tag)} (opened at line {node.sourceline})" if node is not None else "the root element"


# -- reports --------------------------------------------------------------------------------------
_COLUMNS = ["file", "status", "details", "check", "severity", "line", "gml_id", "message"]


def write_report_csv(reports: Sequence[FileReport], path: str) -> None:
    """One row per issue (every file appears, a valid one with empty issue columns); UTF-8 with BOM for Excel."""
    with atomic_file(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8-sig") as out:
            writer = csv.writer(out)
            writer.writerow(_COLUMNS)
            for rep in reports:
                rows: list[Issue | None] = [*rep.issues] or [None]
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
