"""The rules plugins.qgis.org applies to an uploaded plugin ZIP, checked before an upload.

Written from the repository's public source (qgis/QGIS-Plugins-Website: ``qgis-app/plugins/validator.py``, which
refuses an upload, and the file analysis of ``security_scanner.py``, which flags files); its code is not copied.
Stricter where the site only warns or silently drops: several top folders, an icon= naming no file, a boolean
it would read as false, hidden or binary files. ``homepage`` is checked like ``tracker`` and ``repository``: the
validator tests the three URLs alike, so an upload without a homepage fails too.

    python scripts/plugin_zip_check.py ZIP [--online]

prints one line per failed rule and exits 1 when there is one; ``--online`` also asks each URL of the card,
as the site does (a HEAD request, redirects followed, 10 s, an answer below 400).
"""
from __future__ import annotations

import configparser
import io
import re
import sys
import urllib.error
import urllib.parse
import urllib.request
import zipfile
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

#: the site's upload limit, in bytes (its PLUGIN_MAX_UPLOAD_SIZE)
MAX_BYTES = 25_000_000
#: the card fields the site requires (its PLUGIN_REQUIRED_METADATA)
REQUIRED_FIELDS = ("name", "description", "version", "qgisMinimumVersion", "author", "email", "about", "tracker",
                   "repository")
#: the fields only a maintainer can give (``make package`` adds them to the ZIP's card)
MAINTAINER_FIELDS = ("email", "tracker", "repository", "homepage")
URL_FIELDS = ("tracker", "repository", "homepage")
#: the site's own placeholder URLs, refused as they stand
SITE_PLACEHOLDER_URLS = {"tracker": "http://bugs", "repository": "http://repo", "homepage": "http://homepage"}
FORBIDDEN_FOLDERS = ("__MACOSX", ".git", "__pycache__")
#: file endings the site's file analysis flags as executables or binaries
FLAGGED_ENDINGS = (".exe", ".dll", ".so", ".dylib", ".bat", ".sh", ".ps1", ".cmd")
#: hidden files the site's file analysis accepts (git's, and the scanners' configuration files)
ACCEPTED_HIDDEN = (".gitignore", ".gitattributes", ".bandit", ".secrets.baseline", ".flake8")
BOOLEAN_FIELDS = ("experimental", "deprecated", "server")
BOOLEAN_WORDS = ("true", "false", "yes", "no", "1", "0")
#: the site's column sizes (plugins/models.py)
FIELD_LENGTHS = {"name": 256, "author": 256, "version": 32, "qgisMinimumVersion": 32, "qgisMaximumVersion": 32}
#: hosts reserved for examples and tests (RFC 2606, RFC 6761)
PLACEHOLDER_HOSTS = re.compile(r"(^|\.)(example\.(com|org|net)|example|invalid|test|localhost)$")
PLACEHOLDER_WORDS = re.compile(r"your[-_ ]?(name|email|user|org|plugin|repo)|\btodo\b|\btbd\b|\bfixme\b|changeme"
                               r"|\bxxx+\b|<[^>]*>", re.IGNORECASE)
EMAIL = re.compile(r"[^@\s]+@([^@\s]+\.[^@\s.]+)")
QGIS_VERSION = re.compile(r"\d+\.\d+(\.\d+)?")
#: what the site's name check and Python's identifier rule both accept
PACKAGE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]+")
BROWSER = "Mozilla/5.0 (X11; Linux x86_64) WIT-City-Model plugin check"


@dataclass(frozen=True)
class Problem:
    """One failed rule: its name, and the line that says what is wrong."""

    rule: str
    message: str
    #: the card field that is missing, when that is the problem
    missing: str | None = None

    def __str__(self) -> str:
        return f"[{self.rule}] {self.message}"


def placeholder(value: str) -> str | None:
    """Why ``value`` is a placeholder rather than a real address (None when it is not one)."""
    host = value.rsplit("@", 1)[-1] if "@" in value and "://" not in value else urllib.parse.urlsplit(value).hostname
    if host and PLACEHOLDER_HOSTS.search(host.lower()):
        return f"{host} is reserved for examples"
    found = PLACEHOLDER_WORDS.search(value)
    return f"'{found.group(0)}' is a placeholder" if found else None


def field_problems(fields: Mapping[str, str]) -> list[Problem]:
    """The e-mail and URL fields among ``fields`` that are malformed or placeholders."""
    problems = []
    for name, value in fields.items():
        if name not in MAINTAINER_FIELDS or not value:
            continue
        if name == "email":
            if not EMAIL.fullmatch(value):
                problems.append(Problem("email", f"email={value} is not an e-mail address"))
        elif value == SITE_PLACEHOLDER_URLS[name]:
            problems.append(Problem("url", f"{name}={value} is the site's own placeholder"))
        else:
            parts = urllib.parse.urlsplit(value)
            if parts.scheme not in ("http", "https") or not parts.netloc or any(c.isspace() for c in value):
                problems.append(Problem("url", f"{name}={value} is not an http(s) address"))
                continue
        why = placeholder(value)
        if why:
            problems.append(Problem("placeholder", f"{name}={value}: {why}"))
    return problems


def unreachable(url: str, timeout: float = 10.0) -> str | None:
    """Why ``url`` does not answer as the site wants (None when it does): a HEAD request, redirects followed."""
    if urllib.parse.urlsplit(url).scheme not in ("http", "https"):
        return "not an http(s) address"
    request = urllib.request.Request(url, method="HEAD", headers={"User-Agent": BROWSER})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as answer:  # nosec B310  # http(s) only, checked above
            status = answer.status
    except urllib.error.HTTPError as exc:
        status = exc.code
    except (urllib.error.URLError, OSError, ValueError) as exc:
        return f"no answer ({getattr(exc, 'reason', exc)})"
    return f"answers HTTP {status}" if status >= 400 else None


def _names_problems(names: list[str]) -> list[Problem]:
    problems = []
    for name in names:
        if ".." in name or name.startswith("/") or "\\" in name or re.match(r"[A-Za-z]:", name):
            problems.append(Problem("paths", f"{name}: a path that leaves the folder, is absolute or uses \\"))
        if ".pyc" in name:
            problems.append(Problem("forbidden", f"{name}: compiled Python (.pyc) is refused"))
        parts = name.split("/")
        folder = next((f for f in FORBIDDEN_FOLDERS if f in parts), None)
        if folder:
            problems.append(Problem("forbidden", f"{name}: a {folder} folder is refused"))
        base = parts[-1]
        if base.startswith(".") and base not in ACCEPTED_HIDDEN:
            problems.append(Problem("file-analysis", f"{name}: a hidden file is flagged"))
        if base.lower().endswith(FLAGGED_ENDINGS):
            problems.append(Problem("file-analysis", f"{name}: an executable or binary file is flagged"))
    return problems


def _damaged(archive: zipfile.ZipFile) -> list[Problem]:
    """The members that do not read back whole (a CRC or compression error), as the site's testzip() finds."""
    problems = []
    for info in archive.infolist():
        try:
            with archive.open(info) as member:
                while member.read(1 << 20):
                    pass
        except (zipfile.BadZipFile, zlib.error, OSError, NotImplementedError) as exc:
            problems.append(Problem("zip", f"{info.filename}: damaged in the ZIP ({exc})"))
    return problems


def _read_card(archive: zipfile.ZipFile, name: str) -> tuple[configparser.SectionProxy | None, list[Problem]]:
    """The card's [general] section read as the site reads it (interpolation on, keys case-sensitive)."""
    parser = configparser.ConfigParser()
    parser.optionxform = str
    try:
        parser.read_file(io.StringIO(archive.read(name).decode("utf-8")))
        if not parser.has_section("general"):
            return None, [Problem("metadata", f"{name} has no [general] section")]
        parser.items("general")  # the site reads every value through interpolation: a stray % fails there
    except (UnicodeDecodeError, configparser.Error) as exc:
        return None, [Problem("metadata", f"{name} cannot be read as the site reads it: {exc}".replace("\n", " "))]
    return parser["general"], []


def _card_problems(card: configparser.SectionProxy, top: str, names: set[str],
                   reach: Callable[[str], str | None] | None) -> list[Problem]:
    problems = [Problem("required", f"metadata.txt has no {key}=", missing=key)
                for key in (*REQUIRED_FIELDS, "homepage") if not card.get(key, "").strip()]
    values = {key: card.get(key, "").strip() for key in MAINTAINER_FIELDS}
    problems += field_problems(values)
    if reach:
        for key in URL_FIELDS:
            why = values[key] and reach(values[key])
            if why:
                problems.append(Problem("url", f"{key}={values[key]} {why}"))
    if "/" in card.get("author", ""):
        problems.append(Problem("author", "author= contains '/'"))
    if "supportsQt6" in card:
        problems.append(Problem("deprecated", "supportsQt6= is reported as deprecated (qgisMaximumVersion admits 4)"))
    for key, limit in FIELD_LENGTHS.items():
        if len(card.get(key, "").strip()) > limit:
            problems.append(Problem("length", f"{key}= is longer than the site's {limit} characters"))
    if re.search(r"\s", card.get("version", "").strip()):
        problems.append(Problem("version", "version= contains a space (the site keeps only its last word)"))
    for key in ("qgisMinimumVersion", "qgisMaximumVersion"):
        value = card.get(key, "").strip()
        if value and not QGIS_VERSION.fullmatch(value):
            problems.append(Problem("version", f"{key}={value} is not a QGIS version such as 3.22"))
    for key in BOOLEAN_FIELDS:
        value = card.get(key, "").strip().lower()
        if value and value not in BOOLEAN_WORDS:
            problems.append(Problem("boolean", f"{key}={value} is neither true nor false to the site"))
    icon = card.get("icon", "").strip()
    if icon and f"{top}/{icon.removeprefix('./')}" not in names:
        problems.append(Problem("icon", f"icon={icon} names no file of the ZIP"))
    return problems


def check_zip(path: str | Path, *, online: bool = False,
              reach: Callable[[str], str | None] = unreachable) -> list[Problem]:
    """Every rule the ZIP at ``path`` fails (an empty list: it passes); ``online`` also asks its URLs."""
    path = Path(path)
    if path.stat().st_size > MAX_BYTES:
        return [Problem("size", f"{path.name} has {path.stat().st_size:,} bytes; the limit is {MAX_BYTES:,}")]
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        return [Problem("zip", f"{path.name} is not a readable ZIP: {exc}")]
    with archive:
        names = archive.namelist()
        if not names:
            return [Problem("zip", f"{path.name} is empty")]
        problems = _names_problems(names)
        problems += _damaged(archive)
        tops = sorted({n.split("/")[0] for n in names})
        if len(tops) != 1 or "/" not in names[0]:
            return problems + [Problem("top-folder", f"the ZIP must hold one folder, not {', '.join(tops)}")]
        top = tops[0]
        if not (PACKAGE_NAME.fullmatch(top) and top.isidentifier()):
            problems.append(Problem("top-folder", f"{top}: the folder must be an ASCII Python identifier"))
        for entry in names:
            if entry.endswith(".py") and (archive.getinfo(entry).external_attr >> 16) & 0o111:
                problems.append(Problem("file-analysis", f"{entry}: an executable Python file is flagged"))
        for required in ("__init__.py", "metadata.txt", "LICENSE"):
            if f"{top}/{required}" not in names:
                problems.append(Problem("required", f"{top}/{required} is missing"))
        if f"{top}/metadata.txt" in names:
            card, card_problems = _read_card(archive, f"{top}/metadata.txt")
            problems += card_problems
            if card is not None:
                problems += _card_problems(card, top, set(names), reach if online else None)
    return problems


def main(argv: list[str]) -> int:
    paths = [a for a in argv if not a.startswith("--")]
    if len(paths) != 1:
        print("usage: python scripts/plugin_zip_check.py ZIP [--online]")
        return 2
    problems = check_zip(paths[0], online="--online" in argv)
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
