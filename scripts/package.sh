#!/usr/bin/env bash
# make package: dist/wit_citymodel-<version>.zip, installable with QGIS's "Install from ZIP".
# Holds the plugin only (tracked files of the plugin folders, or every file but caches in a copy
# without git, + compiled translations);
# no tests, CI, scripts, benchmarks or outputs.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh >/dev/null
.venv/bin/python scripts/changelog.py --check >&2  # the card's changelog= as CHANGELOG.md says
.venv/bin/python - <<'PY'
import configparser, subprocess, zipfile
from pathlib import Path

INCLUDE = ["metadata.txt", "__init__.py", "plugin.py", "icon.svg", "LICENSE", "README.md", "CHANGELOG.md",
           "requirements.txt", "wit_plugin", "processing_provider", "i18n"]
version = configparser.ConfigParser(interpolation=None)
version.read("metadata.txt", encoding="utf-8")
version = version["general"]["version"]
listed = subprocess.run(["git", "ls-files", "-z", "--", *INCLUDE], capture_output=True)
if listed.returncode == 0:  # a git checkout: its tracked files
    tracked = listed.stdout.decode().split("\0")
else:  # a copy without git (a source archive, the test chroots): every file but caches
    tracked = [str(p) for entry in INCLUDE for p in ([Path(entry)] if Path(entry).is_file() else Path(entry).rglob("*"))
               if "__pycache__" not in p.parts and p.suffix != ".pyc"]
files = sorted({f for f in tracked if f and Path(f).is_file()} | {str(p) for p in Path("i18n").glob("*.qm")})
dist = Path("dist")
dist.mkdir(exist_ok=True)
target = dist / f"wit_citymodel-{version}.zip"
tmp = target.with_suffix(".zip.tmp")
with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as archive:
    for name in files:
        archive.write(name, f"wit_citymodel/{name}")
tmp.replace(target)
print(target)
PY
