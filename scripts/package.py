"""make package: ``dist/wit_citymodel-<version>.zip``, for QGIS's "Install from ZIP", and for plugins.qgis.org
when the maintainer's fields are given (scripts/plugin_zip.py says where from).

    python scripts/package.py [--output-dir DIR]

A placeholder or malformed field stops it before anything is built. The ZIP is built beside its target, then
checked against the repository's rules (scripts/plugin_zip_check.py; ``WIT_PACKAGE_CHECK_URLS=1`` also asks
the card's URLs, as the site does) and scanned as the site scans it (scripts/security_scan.py); only a ZIP
that passes replaces the old one. Without the maintainer's fields the ZIP is still made, and one line says
what an upload needs. The last line of the output is the ZIP's path.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import plugin_zip
import plugin_zip_check
import security_scan


def upload_note(missing: list[str]) -> str:
    """The one line that says what an upload to plugins.qgis.org still needs."""
    variables = ", ".join(plugin_zip.ENVIRONMENT[field] for field in missing)
    return (f"Not ready for plugins.qgis.org: the card lacks {', '.join(missing)}; give them in "
            f"{plugin_zip.SETTINGS_FILE.name} [{plugin_zip.SETTINGS_SECTION}] or {variables} (README: Publishing). "
            f"This ZIP installs with Install from ZIP.")


def package(output_dir: Path, environ: dict[str, str]) -> tuple[Path, list[str]]:
    """Build, check and scan the ZIP into ``output_dir``; its path and the lines that refuse it (none: done)."""
    try:
        fields = plugin_zip.maintainer_fields(environ)
    except plugin_zip.SettingsError as exc:
        return Path(), [f"[settings] {exc}"]
    refused = [str(p) for p in plugin_zip_check.field_problems(fields)]
    if refused:
        return Path(), refused
    output_dir.mkdir(parents=True, exist_ok=True)
    target = output_dir / f"wit_citymodel-{plugin_zip.version()}.zip"
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        plugin_zip.build(tmp, fields)
        problems = plugin_zip_check.check_zip(tmp, online=environ.get("WIT_PACKAGE_CHECK_URLS") == "1")
        missing = [p.missing for p in problems if p.missing in plugin_zip_check.MAINTAINER_FIELDS]
        refused = [str(p) for p in problems if p.missing not in plugin_zip_check.MAINTAINER_FIELDS]
        refused += [str(f) for f in security_scan.scan_zip(tmp)]
        if refused:
            return target, refused
        tmp.replace(target)
    finally:
        tmp.unlink(missing_ok=True)
    if missing:
        print(upload_note(missing), file=sys.stderr)
    return target, []


def main(argv: list[str]) -> int:
    output_dir = Path(argv[argv.index("--output-dir") + 1]) if "--output-dir" in argv else plugin_zip.ROOT / "dist"
    target, refused = package(output_dir, dict(os.environ))
    for line in refused:
        print(line, file=sys.stderr)
    if refused:
        print(f"make package: no ZIP written ({len(refused)} problem(s) above)", file=sys.stderr)
        return 1
    print(target)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
