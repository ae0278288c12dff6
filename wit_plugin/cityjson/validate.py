"""Offline validation of CityJSON 2.0 (``.city.json``) and CityJSONSeq (``.city.jsonl``) files.

The same verdicts as ``citygml.validate`` gives the CityGML of the same model, with the same checks and
tolerances where the encodings meet: the official schemas (``schema``; the CityGML's XSD), unique ids, every
``parents``/``children`` reference resolving both ways, vertex indices, building solids closed, outward,
planar and simple (the CityGML validator's ``geometry.SolidCheck``), TIN triangles not degenerate, texture
images present and texture values matching their rings (``checks``). Files that are empty, not JSON or not
CityJSON get one message saying so.

Memory: a ``.city.json`` is read whole (one JSON value; Python's parser needs it all), a ``.city.jsonl`` a
line at a time: a tiled run's sequences are checked in the memory of their largest feature.

Image paths are relative to the file's folder; for a tile's sequence of a run (its images named from the
run's folder, so that the tiles' sequences join) to the folder above that holds the run's ``index.city.jsonl``.
"""
from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from ..citygml.validate import file_start
from ..citygml.validation.names import FileReport, Issue, IssueList
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from . import schema
from .checks import ModelCheck
from .sequence import RUN_INDEX

SUFFIXES = (".city.json", ".city.jsonl", ".json", ".jsonl")


class CityJSONFileReport(FileReport):
    """A CityJSON file's report: its summary names the schema, not an XSD."""

    @property
    def details(self) -> str:
        return super().details if self.issues else "valid (schema, ids, references, geometry, textures)"


def is_cityjson(path: str | Path) -> bool:
    return str(path).lower().endswith(SUFFIXES)


def image_folder_of(path: Path) -> Path:
    """The folder a file's relative image paths start from (see the module docstring)."""
    if path.name.lower().endswith(".jsonl"):
        for folder in (path.parent, path.parent.parent, path.parent.parent.parent):
            if (folder / RUN_INDEX).is_file():
                return folder
    return path.parent


def validate_cityjson_files(paths: Sequence[str], feedback: Feedback = SILENT, planarity_tol: float = 0.01,
                            vertex_tol: float = 0.001, min_triangle_area: float = 1e-6,
                            max_issues_per_check: int = 200,
                            image_folder: Callable[[Path], Path] = image_folder_of,
                            strip_prefix: str = "") -> list[FileReport]:
    """Validate CityJSON files (tolerances as ``citygml.validate.validate_files``); one report per file.

    ``image_folder``: the folder a file's relative image paths start from, less ``strip_prefix`` (a tile's
    sequence checked before it is in its run's folder).
    """
    files = [Path(p) for p in paths]
    if not files:
        raise InputError("No CityJSON files given: choose at least one .city.json or .city.jsonl file to validate.")
    for path in files:
        if not path.is_file():
            raise InputError(f"CityJSON file {path} does not exist or is not a file.")
    if not schema.available():
        feedback.warning(f"The CityJSON schemas are not checked: fastjsonschema is not installed ({schema.INSTALL}).")
    reports: list[FileReport] = []
    for number, path in enumerate(files):
        feedback.check_canceled()
        feedback.info(f"Validating {path.name}")
        start = time.perf_counter()
        issues = IssueList(str(path), max_issues_per_check)
        check = ModelCheck(issues, (image_folder(path), strip_prefix), (planarity_tol, vertex_tol, min_triangle_area),
                           feedback)
        _validate(path, check, issues)
        closed = issues.closed()
        report = CityJSONFileReport(str(path), not any(i.severity == "error" for i in closed), closed,
                                    path.stat().st_size, time.perf_counter() - start)
        feedback.info(f"{path.name}: {report.status} ({report.details})")
        reports.append(report)
        feedback.progress(100.0 * (number + 1) / len(files))
    return reports


def _validate(path: Path, check: ModelCheck, issues: IssueList) -> None:
    problem = _not_json(path)
    if problem:
        issues.add("json", None, None, problem)
        return
    if path.name.lower().endswith(".jsonl"):
        _sequence(path, check, issues)
        return
    try:
        with open(path, encoding="utf-8-sig") as stream:
            document = json.load(stream, object_pairs_hook=_DuplicateKeys(issues, None))
    except (ValueError, UnicodeDecodeError) as exc:
        issues.add("json", getattr(exc, "lineno", None), None, f"The file is not valid JSON: {exc}.")
        return
    if _not_cityjson(document, "CityJSON", issues, None):
        return
    check.document(document, None)
    check.finish()


def _sequence(path: Path, check: ModelCheck, issues: IssueList) -> None:
    """The header line (a CityJSON object with the transform), then one CityJSONFeature a line."""
    header = None
    for line, text in _lines(path, issues):
        try:
            value = json.loads(text, object_pairs_hook=_DuplicateKeys(issues, line))
        except ValueError as exc:
            issues.add("json", line, None, f"Line {line} is not valid JSON: {exc}.")
            continue
        if header is None:
            if _not_cityjson(value, "CityJSON", issues, line):
                return
            header = value
            check.document(value, line)
        elif not _not_cityjson(value, "CityJSONFeature", issues, line):
            check.feature(value, line)
    if header is None:
        issues.add("json", None, None, "The sequence has no line: there is nothing to validate.")
        return
    check.finish()


def _lines(path: Path, issues: IssueList) -> Iterator[tuple[int, str]]:
    with open(path, encoding="utf-8-sig", errors="strict") as stream:
        try:
            for number, text in enumerate(stream, 1):
                if text.strip():
                    yield number, text
        except UnicodeDecodeError as exc:
            issues.add("json", None, None, f"The file is not UTF-8 text: {exc}.")


def _not_json(path: Path) -> str | None:
    """Why the file is no JSON at all (empty, white space, binary, XML), or None."""
    text, problem = file_start(path, "JSON")
    if problem:
        return problem
    start = text.lstrip()[:1]
    if start == b"{" or not start:
        return None
    if start == b"<":
        return "The file is XML (CityGML?), not JSON: validate it as CityGML."
    return f"The file is not JSON: it starts with {text.lstrip()[:4]!r}, not with '{{'."


def _not_cityjson(value: object, kind: str, issues: IssueList, line: int | None) -> bool:
    """True (with the issue) when ``value`` is not a JSON object of type ``kind``."""
    found = value.get("type") if isinstance(value, dict) else None
    if found == kind:
        return False
    where = f"line {line}" if line else "the file"
    if kind == "CityJSON" and isinstance(value, dict) and found == "FeatureCollection":
        message = f"{where} is GeoJSON, not CityJSON."
    else:
        message = f"{where[0].upper()}{where[1:]} is not a {kind} object (its \"type\" is {found!r})."
    issues.add("json", line, None, message)
    return True


class _DuplicateKeys:
    """``object_pairs_hook`` reporting a key given twice in one object (JSON parsers keep the last): in
    ``CityObjects`` it is a city object id used twice."""

    def __init__(self, issues: IssueList, line: int | None):
        self.issues, self.line = issues, line

    def __call__(self, pairs: list[tuple[str, object]]) -> dict:
        result = dict(pairs)
        if len(result) < len(pairs):
            seen: set[str] = set()
            for key, _ in pairs:
                if key in seen:
                    self.issues.add("duplicate-id", self.line, key, f"'{key}' is given twice in one JSON object (a "
                                    "city object id must be unique; readers keep only the last).")
                seen.add(key)
        return result


__all__ = ["FileReport", "Issue", "validate_cityjson_files"]
