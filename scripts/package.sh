#!/usr/bin/env bash
# make package: dist/wit_citymodel-<version>.zip, installable with QGIS's "Install from ZIP" and, with the
# maintainer's fields, uploadable to plugins.qgis.org: set-up, the card's changelog checked against
# CHANGELOG.md, then scripts/package.py (build, the repository's rules, its security scan). ARGS go to it
# (--output-dir DIR).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh >/dev/null
.venv/bin/python scripts/changelog.py --check >&2  # the card's changelog= as CHANGELOG.md says
exec .venv/bin/python scripts/package.py "$@"
