"""What the plugin ZIP holds, and the maintainer's fields its card gets (``make package``, the security scan).

The ZIP holds the plugin only: the tracked files of the plugin's folders (every file but caches in a copy
without git: a source archive, the test chroots) and the compiled translations; no tests, CI, scripts,
benchmarks or outputs. One top folder, ``wit_citymodel``.

The maintainer's fields (``email``, ``tracker``, ``repository``, ``homepage``) are not in ``metadata.txt``: the
project has no addresses to publish, and the card says only what is true. A maintainer gives them in
``WIT_PLUGIN_EMAIL``, ``WIT_PLUGIN_TRACKER``, ``WIT_PLUGIN_REPOSITORY`` and ``WIT_PLUGIN_HOMEPAGE``, or in the
``[maintainer]`` section of ``.plugin-maintainer.ini`` (kept out of git; ``WIT_PLUGIN_MAINTAINER_FILE`` names
another file); the environment wins. They go into the ZIP's copy of the card only.
"""
from __future__ import annotations

import configparser
import os
import re
import subprocess
import zipfile
from collections.abc import Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOP_FOLDER = "wit_citymodel"
INCLUDE = ("metadata.txt", "__init__.py", "plugin.py", "icon.svg", "LICENSE", "README.md", "CHANGELOG.md",
           "requirements.txt", "wit_plugin", "processing_provider", "i18n")
SETTINGS_FILE = ROOT / ".plugin-maintainer.ini"
SETTINGS_SECTION = "maintainer"
#: each maintainer's field and the environment variable that gives it, in the card's order
ENVIRONMENT = {"email": "WIT_PLUGIN_EMAIL", "homepage": "WIT_PLUGIN_HOMEPAGE", "tracker": "WIT_PLUGIN_TRACKER",
               "repository": "WIT_PLUGIN_REPOSITORY"}


class SettingsError(Exception):
    """The maintainer's settings cannot be used (the message says why)."""


def card_text() -> str:
    return (ROOT / "metadata.txt").read_text(encoding="utf-8")


def version() -> str:
    card = configparser.ConfigParser(interpolation=None)
    card.read_string(card_text())
    return card["general"]["version"]


def plugin_files(root: Path = ROOT) -> list[str]:
    """The ZIP's files, relative to ``root``, sorted."""
    listed = subprocess.run(["git", "ls-files", "-z", "--", *INCLUDE], capture_output=True, cwd=root)
    if listed.returncode == 0:  # a git checkout: its tracked files
        files = [f for f in listed.stdout.decode().split("\0") if f]
    else:  # a copy without git: every file but caches
        files = [str(p.relative_to(root)) for entry in INCLUDE
                 for p in ([root / entry] if (root / entry).is_file() else (root / entry).rglob("*"))
                 if "__pycache__" not in p.parts and p.suffix != ".pyc"]
    compiled = [str(p.relative_to(root)) for p in (root / "i18n").glob("*.qm")]
    return sorted({f for f in files if (root / f).is_file()} | set(compiled))


def maintainer_fields(environ: Mapping[str, str] = os.environ) -> dict[str, str]:
    """The maintainer's fields that are given (see the module docstring), in the card's order."""
    named = environ.get("WIT_PLUGIN_MAINTAINER_FILE")
    path = Path(named) if named else SETTINGS_FILE
    from_file: dict[str, str] = {}
    if named and not path.is_file():
        raise SettingsError(f"WIT_PLUGIN_MAINTAINER_FILE={named}: no such file")
    if path.is_file():
        parser = configparser.ConfigParser(interpolation=None)
        try:
            parser.read(path, encoding="utf-8")
        except (configparser.Error, UnicodeDecodeError) as exc:
            raise SettingsError(f"{path} cannot be read: {exc}".replace("\n", " ")) from exc
        if parser.has_section(SETTINGS_SECTION):
            from_file = dict(parser[SETTINGS_SECTION])
        unknown = sorted(set(from_file) - set(ENVIRONMENT))
        if unknown or not parser.has_section(SETTINGS_SECTION):
            raise SettingsError(f"{path}: give {', '.join(ENVIRONMENT)} in a [{SETTINGS_SECTION}] section"
                                + (f" (unknown: {', '.join(unknown)})" if unknown else ""))
    fields = {key: (environ.get(variable) or from_file.get(key) or "").strip() for key, variable in ENVIRONMENT.items()}
    return {key: value for key, value in fields.items() if value}


def card_with(card: str, fields: Mapping[str, str]) -> str:
    """``card`` (metadata.txt's text) with ``fields`` set: an existing line replaced, a new one after author=."""
    added = ""
    for key, value in fields.items():
        if "\n" in value:
            raise SettingsError(f"{key}: one line only")
        line = re.compile(rf"^{re.escape(key)}=.*\n", re.MULTILINE)
        if line.search(card):
            card = line.sub(lambda _, text=f"{key}={value}\n": text, card, count=1)
        else:
            added += f"{key}={value}\n"
    author = re.compile(r"^author=.*\n", re.MULTILINE)
    if added and not author.search(card):
        raise SettingsError("metadata.txt has no author= line to put the maintainer's fields after")
    return author.sub(lambda found: found.group(0) + added, card, count=1) if added else card


def build(target: Path, fields: Mapping[str, str], root: Path = ROOT) -> None:
    """Write the ZIP to ``target`` (the caller makes that atomic), its card with ``fields``."""
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        for name in plugin_files(root):
            if name == "metadata.txt":
                archive.writestr(f"{TOP_FOLDER}/{name}", card_with(card_text(), fields))
            else:
                archive.write(root / name, f"{TOP_FOLDER}/{name}")
