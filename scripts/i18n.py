"""Keep i18n/*.ts in step with the code: every user-visible string of the plugin.

Collects ``tr("…")`` / ``self.tr("…")`` / ``translatable("…")`` literals and the ``display_name``, ``group_name`` and
``help_text`` class attributes of the algorithms (they are translated through ``tr`` at run
time), adds new ones to each .ts (unfinished for Korean, identity for English), drops strings
the code no longer has and keeps existing translations. ``--check`` only reports.
``--translate ko FILE`` fills translations from a UTF-8 file of "source<TAB>translation" lines.
Usage: python scripts/i18n.py [--check | --translate CODE FILE]
"""
from __future__ import annotations

import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONTEXT = "WitCityModel"
SOURCES = ["plugin.py", "processing_provider", "wit_plugin/infra/installer.py"]  # the installer speaks to QGIS users
TRANSLATED_ATTRIBUTES = {"display_name", "group_name", "help_text"}
LANGUAGES = {"en": "en_US", "ko": "ko_KR"}


def source_files() -> list[Path]:
    files = []
    for entry in SOURCES:
        path = ROOT / entry
        files.extend(sorted(path.rglob("*.py")) if path.is_dir() else [path])
    return files


def user_strings() -> list[str]:
    """Every translatable literal, in order of first appearance."""
    found: dict[str, None] = {}
    for file in source_files():
        for node in ast.walk(ast.parse(file.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and node.args:
                func = node.func
                name = func.id if isinstance(func, ast.Name) else getattr(func, "attr", None)
                arg = node.args[0]
                if name in ("tr", "translatable") and isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    found[arg.value] = None
            elif isinstance(node, ast.ClassDef):
                for stmt in node.body:
                    if (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1
                            and isinstance(stmt.targets[0], ast.Name)
                            and stmt.targets[0].id in TRANSLATED_ATTRIBUTES
                            and isinstance(stmt.value, ast.Constant) and stmt.value.value):
                        found[stmt.value.value] = None
    return list(found)


def read_ts(path: Path) -> dict[str, tuple[str, bool]]:
    """source -> (translation, finished)"""
    if not path.exists():
        return {}
    result = {}
    for message in ET.parse(path).getroot().iter("message"):
        translation = message.find("translation")
        finished = translation.get("type") not in ("unfinished", "obsolete")
        result[message.findtext("source")] = (translation.text or "", finished)
    return result


def write_ts(path: Path, language: str, strings: list[str], known: dict[str, tuple[str, bool]]) -> None:
    root = ET.Element("TS", version="2.1", language=language)
    context = ET.SubElement(root, "context")
    ET.SubElement(context, "name").text = CONTEXT
    for text in strings:
        message = ET.SubElement(context, "message")
        ET.SubElement(message, "source").text = text
        translation, finished = known.get(text, ("", False))
        if language.startswith("en"):
            translation, finished = text, True
        element = ET.SubElement(message, "translation")
        element.text = translation
        if not finished:
            element.set("type", "unfinished")
    ET.indent(root)
    body = ET.tostring(root, encoding="unicode")
    path.write_text('<?xml version="1.0" encoding="utf-8"?>\n<!DOCTYPE TS>\n' + body + "\n", encoding="utf-8")


def untranslated() -> dict[str, list[str]]:
    """Per .ts file, the code's strings that have no finished translation there."""
    strings = user_strings()
    report = {}
    for code in LANGUAGES:
        known = read_ts(ROOT / "i18n" / f"wit_citymodel_{code}.ts")
        report[code] = [s for s in strings if not known.get(s, ("", False))[1] or not known[s][0]]
    return report


def main(argv: list[str]) -> int:
    if "--check" in argv:
        missing = untranslated()
        for code, texts in missing.items():
            for text in texts:
                print(f"{code}: untranslated: {text[:70]!r}")
        return 1 if any(missing.values()) else 0
    strings = user_strings()
    if "--translate" in argv:
        code, table = argv[argv.index("--translate") + 1:][:2]
        path = ROOT / "i18n" / f"wit_citymodel_{code}.ts"
        known = read_ts(path)
        for line in Path(table).read_text(encoding="utf-8").splitlines():
            if "\t" in line:
                source, translation = line.split("\t", 1)
                known[source] = (translation, True)
        write_ts(path, LANGUAGES[code], strings, known)
        return 0
    for code, language in LANGUAGES.items():
        path = ROOT / "i18n" / f"wit_citymodel_{code}.ts"
        write_ts(path, language, strings, read_ts(path))
    print(f"{len(strings)} strings in {len(LANGUAGES)} .ts files")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
