"""pip for a Python that has none (or one too old): pip's own wheel, from the package index pip would use.

Debian's and Ubuntu's QGIS packages do not pull ``python3-pip``, so QGIS's Python often has no pip. pip runs
from its wheel file (``python pip-X-py3-none-any.whl/pip install …``, the way pip documents for bootstrapping),
so nothing is installed for pip itself: the installer downloads the wheel into its work folder, inside the QGIS
profile, and deletes it with that folder.

The index is the one pip would use for this Python: ``PIP_INDEX_URL``, else ``index-url`` from pip's
configuration files (read in pip's order, the later file winning, ``[install]`` over any ``[global]``), else PyPI;
then the ``extra-index-url`` ones. ``PIP_CERT`` / ``cert`` is the CA bundle for https; proxies come from the
environment, as for pip. Yanked and pre-release pips and those whose Requires-Python excludes this Python are
skipped; the newest left wins. The download is read in chunks (Cancel stops it) and checked against the sha256
the index gives.
"""
from __future__ import annotations

import configparser
import hashlib
import os
import re
import ssl
import sys
import urllib.parse
import urllib.request
from collections.abc import Mapping
from dataclasses import dataclass
from html.parser import HTMLParser
from pathlib import Path

from .errors import CanceledError, WitError
from .feedback import SILENT, Feedback

PYPI = "https://pypi.org/simple/"
#: ``pip install --dry-run --report`` needs pip 22.2
MINIMUM_PIP = (22, 2)
WHEEL = re.compile(r"pip-(?P<version>\d+(\.\d+)*)-py3(\.py\d+)*-none-any\.whl")
TIMEOUT = 60
CHUNK = 1 << 16


class PipBootstrapError(WitError):
    """pip's wheel could not be found or fetched (the message says where and why)."""


@dataclass(frozen=True)
class PipSettings:
    """What pip's configuration says about where packages come from."""

    indexes: tuple[str, ...]
    #: a CA bundle for https (pip's ``cert``), else the system's
    cafile: str | None = None


@dataclass(frozen=True)
class PipWheel:
    url: str
    version: tuple[int, ...]
    #: the sha256 the index gives in the link (``#sha256=…``), if any
    sha256: str | None
    cafile: str | None = None

    @property
    def filename(self) -> str:
        return urllib.parse.unquote(urllib.parse.urlsplit(self.url).path.rsplit("/", 1)[-1])

    @property
    def version_text(self) -> str:
        return ".".join(map(str, self.version))


def config_files(environ: Mapping[str, str] = os.environ, platform: str = sys.platform) -> list[Path]:
    """pip's configuration files for this user and Python, lowest priority first (pip's own order)."""
    home = Path(environ.get("HOME") or Path.home())
    named = environ.get("PIP_CONFIG_FILE")
    if named == os.devnull:
        return []
    if platform.startswith("win"):
        data = Path(environ.get("ProgramData", r"C:\ProgramData"))
        appdata = Path(environ.get("APPDATA", home / "AppData" / "Roaming"))
        global_files, user_files, name = [data / "pip" / "pip.ini"], [home / "pip" / "pip.ini",
                                                                      appdata / "pip" / "pip.ini"], "pip.ini"
    elif platform == "darwin":
        support = Path("Library") / "Application Support" / "pip"
        global_files = [Path("/") / support / "pip.conf"]
        user_files, name = [home / ".pip" / "pip.conf", home / ".config" / "pip" / "pip.conf",
                            home / support / "pip.conf"], "pip.conf"
    else:
        dirs = (environ.get("XDG_CONFIG_DIRS") or "/etc/xdg").split(os.pathsep)
        global_files = [Path(d) / "pip" / "pip.conf" for d in dirs if d] + [Path("/etc/pip.conf")]
        config_home = Path(environ.get("XDG_CONFIG_HOME") or home / ".config")
        user_files, name = [home / ".pip" / "pip.conf", config_home / "pip" / "pip.conf"], "pip.conf"
    if named and Path(named).exists():
        user_files = []  # pip reads no user file when PIP_CONFIG_FILE names one that exists
    return global_files + user_files + [Path(sys.prefix) / name] + ([Path(named)] if named else [])


def pip_settings(environ: Mapping[str, str] = os.environ, platform: str = sys.platform) -> PipSettings:
    """The indexes (``index-url`` first, then the extra ones) and the CA bundle pip would use."""
    parsers = []
    for path in config_files(environ, platform):
        parser = configparser.RawConfigParser()
        try:
            parser.read(path, encoding="utf-8")
        except (configparser.Error, OSError, UnicodeDecodeError):
            continue  # pip would stop on a broken file; the index falls back to PyPI here
        parsers.append(parser)
    values: dict[str, str] = {}
    for section in ("global", "install"):  # pip: [install] of any file over [global] of any file
        for parser in parsers:
            if parser.has_section(section):
                values.update({key.replace("_", "-"): value for key, value in parser.items(section)})
    for key in ("index-url", "extra-index-url", "cert", "no-index"):
        variable = "PIP_" + key.upper().replace("-", "_")
        if environ.get(variable):
            values[key] = environ[variable]
    if values.get("no-index", "").strip().lower() in ("1", "true", "yes", "on"):
        return PipSettings((), values.get("cert"))
    indexes = [values.get("index-url", "").strip() or PYPI] + values.get("extra-index-url", "").split()
    return PipSettings(tuple(dict.fromkeys(i.strip() for i in indexes if i.strip())), values.get("cert") or None)


def _open(url: str, cafile: str | None):
    """A response for ``url``: http(s) with the CA bundle, or a file of a local index (a folder: its index.html)."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme == "file":
        path = Path(urllib.request.url2pathname(parts.path))
        return open(path / "index.html" if path.is_dir() else path, "rb")
    if parts.scheme not in ("http", "https"):
        raise PipBootstrapError(f"{url}: not an http(s) or file address")
    context = ssl.create_default_context(cafile=cafile) if cafile else None
    request = urllib.request.Request(url, headers={"User-Agent": "pip (WIT City Model bootstrap)",
                                                   "Accept": "text/html"})
    return urllib.request.urlopen(request, timeout=TIMEOUT, context=context)  # nosec B310  # http(s), checked


class _Links(HTMLParser):
    """The links of a PEP 503 project page, with their attributes."""

    def __init__(self):
        super().__init__()
        self.links: list[dict[str, str | None]] = []

    def handle_starttag(self, tag, attrs):
        if tag == "a":
            self.links.append(dict(attrs))


def python_fits(requires: str | None, version: tuple[int, ...] = tuple(sys.version_info[:3])) -> bool:
    """Whether ``version`` meets a Requires-Python such as ">=3.9, !=3.10.*" (False when it cannot be read)."""
    for clause in filter(None, (c.strip() for c in (requires or "").split(","))):
        found = re.fullmatch(r"(~=|==|!=|<=|>=|<|>)\s*(\d+(?:\.\d+)*)(\.\*)?", clause)
        if not found:
            return False
        operator, number, wildcard = found.groups()
        wanted = tuple(map(int, number.split(".")))
        if wildcard:  # "==3.10.*": the leading numbers only
            if operator not in ("==", "!="):
                return False
            ok = (version[:len(wanted)] == wanted) == (operator == "==")
        else:
            size = max(len(wanted), len(version))
            have, want = (v + (0,) * (size - len(v)) for v in (version, wanted))
            ok = {"==": have == want, "!=": have != want, "<=": have <= want, ">=": have >= want,
                  "<": have < want, ">": have > want,
                  "~=": have >= want and version[:len(wanted) - 1] == wanted[:-1]}[operator]
        if not ok:
            return False
    return True


def newest_wheel(page: str, base_url: str, cafile: str | None = None) -> PipWheel | None:
    """The newest pip wheel on a project page that suits this Python and the installer, or None."""
    parser = _Links()
    parser.feed(page)
    found = []
    for link in parser.links:
        href = link.get("href") or ""
        url = urllib.parse.urljoin(base_url, href)
        name = urllib.parse.unquote(urllib.parse.urlsplit(url).path.rsplit("/", 1)[-1])
        match = WHEEL.fullmatch(name)
        if not match or "data-yanked" in link or not python_fits(link.get("data-requires-python")):
            continue
        version = tuple(map(int, match.group("version").split(".")))
        if version >= MINIMUM_PIP:
            digest = re.search(r"sha256=([0-9a-fA-F]{64})", urllib.parse.urlsplit(url).fragment)
            found.append(PipWheel(url.split("#")[0], version, digest.group(1).lower() if digest else None, cafile))
    return max(found, key=lambda wheel: wheel.version, default=None)


def find_pip(settings: PipSettings) -> PipWheel:
    """pip's newest suitable wheel on the first index that has one; raises with each index's reason."""
    reasons = []
    for index in settings.indexes:
        page_url = index.rstrip("/") + "/pip/"
        try:
            with _open(page_url, settings.cafile) as answer:
                page = answer.read().decode("utf-8", errors="replace")
        except (OSError, ValueError, PipBootstrapError) as exc:
            reasons.append(f"{page_url}: {getattr(exc, 'reason', exc)}")
            continue
        wheel = newest_wheel(page, page_url, settings.cafile)
        if wheel:
            return wheel
        reasons.append(f"{page_url}: no pip wheel ≥ 22.2 for Python {sys.version_info[0]}.{sys.version_info[1]}")
    raise PipBootstrapError("; ".join(reasons) or "pip's configuration says no-index")


def download(wheel: PipWheel, folder: Path, feedback: Feedback = SILENT) -> Path:
    """The wheel saved in ``folder`` (checked against its sha256); Cancel stops it and leaves no file."""
    if not WHEEL.fullmatch(wheel.filename):
        raise PipBootstrapError(f"{wheel.url}: not a pip wheel")
    target = folder / wheel.filename
    partial = folder / (wheel.filename + ".part")
    digest = hashlib.sha256()
    try:
        with _open(wheel.url, wheel.cafile) as answer, open(partial, "wb") as out:
            while chunk := answer.read(CHUNK):
                if feedback.is_canceled():
                    raise CanceledError("Cancelled: pip's wheel was not downloaded.")
                digest.update(chunk)
                out.write(chunk)
        if wheel.sha256 and digest.hexdigest() != wheel.sha256:
            raise PipBootstrapError(f"{wheel.url}: the download does not match the index's sha256")
        partial.replace(target)
    except (OSError, ValueError) as exc:
        raise PipBootstrapError(f"{wheel.url}: {getattr(exc, 'reason', exc)}") from exc
    finally:
        partial.unlink(missing_ok=True)
    return target
