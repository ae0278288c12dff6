#!/usr/bin/env bash
# Idempotent set-up for a fresh Debian 12 machine: system packages (QGIS, GDAL, xmllint, lrelease),
# a .venv on QGIS's Python with the few extra packages, and compiled translations.
# Every step checks whether it is already done, so running it again costs a second or two.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
SYS_PY=/usr/bin/python3
log() { printf '[setup] %s\n' "$*" >&2; did=1; }
did=0

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

need_apt=()
"$SYS_PY" -c 'import qgis.core' 2>/dev/null || need_apt+=(qgis python3-qgis qgis-providers)
"$SYS_PY" -c 'from osgeo import gdal' 2>/dev/null || need_apt+=(python3-gdal)
command -v gdal_translate >/dev/null || need_apt+=(gdal-bin)
command -v qgis_process.bin >/dev/null || need_apt+=(qgis-providers)
command -v xmllint >/dev/null || need_apt+=(libxml2-utils)
command -v lrelease >/dev/null || need_apt+=(qttools5-dev-tools)
command -v geos-config >/dev/null || need_apt+=(libgeos-dev)  # shapely is built against it
command -v Xvfb >/dev/null || need_apt+=(xvfb)  # the real QGIS window in tests and screenshots
[ -d /usr/share/fonts/truetype/nanum ] || need_apt+=(fonts-nanum)  # Korean labels render as boxes without
[ -f /usr/include/python3.11/Python.h ] || need_apt+=(python3-dev)
command -v g++ >/dev/null || need_apt+=(g++)  # meshoptimizer (the 3D Tiles web profile) is built from source
"$SYS_PY" -c 'import venv, ensurepip' 2>/dev/null || need_apt+=(python3-venv)
if [ ${#need_apt[@]} -gt 0 ]; then
    log "installing system packages: ${need_apt[*]}"
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

# Python environment: QGIS's interpreter, system site-packages visible (qgis, osgeo, numpy).
if [ ! -x .venv/bin/python ]; then
    log "creating .venv"
    "$SYS_PY" -m venv --system-site-packages .venv
fi
NUMPY_VERSION="$("$SYS_PY" -c 'import numpy; print(numpy.__version__)')"
STAMP=".venv/.wit-requirements"
WANT="$(cat requirements.txt requirements-dev.txt; echo "numpy==$NUMPY_VERSION")"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$WANT" ]; then
    log "installing Python packages (numpy pinned to the system's $NUMPY_VERSION)"
    printf 'numpy==%s\n' "$NUMPY_VERSION" > .venv/constraints.txt
    .venv/bin/python -m pip install -q --disable-pip-version-check \
        -c .venv/constraints.txt -r requirements-dev.txt
    printf '%s' "$WANT" > "$STAMP"
fi

# Translations: .ts (source, committed) -> .qm (compiled, ignored by git).
shopt -s nullglob
for ts in i18n/*.ts; do
    qm="${ts%.ts}.qm"
    if [ ! -f "$qm" ] || [ "$ts" -nt "$qm" ]; then
        lrelease -silent "$ts" -qm "$qm"
    fi
done
# PostgreSQL driver for PostGIS colour stores: Debian's python3-psycopg2 (python3-qgis depends on
# it; built on Debian's libpq), not a pip wheel bundling its own libpq. The server itself is only
# needed by the tests (scripts/test.sh starts it with scripts/postgis.sh).
if ! "$SYS_PY" -c 'import psycopg2' 2>/dev/null; then
    log "installing python3-psycopg2"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-psycopg2 >/dev/null
fi
# The web viewer and the browser tests: Node.js, Chromium, the pinned npm packages (viewer/).
bash scripts/setup-viewer.sh
[ "$did" = 0 ] || printf '[setup] ready\n' >&2
