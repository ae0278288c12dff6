#!/usr/bin/env bash
# Idempotent set-up for a Debian-family machine with QGIS from its distribution: Debian 12 (QGIS 3.22,
# or 3.40 from bookworm-backports) and Debian testing/sid (QGIS 3.44, Python 3.13/3.14). System
# packages (QGIS, GDAL, xmllint, lrelease, what builds need), a venv on QGIS's Python with the few
# extra packages, and compiled translations.
# Every step checks whether it is already done, so running it again costs a second or two.
# WIT_SETUP_VIEWER=0: no web viewer (scripts/setup-viewer.sh; the QGIS-version test chroot goes without).
# WIT_TRIANGLE=0: no `triangle` (Triangle is free for non-commercial use only): the terrain uses CDT
# (MPL-2.0) alone; `make demo` works so, `make test` needs both backends.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
SYS_PY=/usr/bin/python3
VENV=.venv
log() { printf '[setup] %s\n' "$*" >&2; did=1; }
did=0

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
apt_updated=0
apt_install() {
    log "installing system packages: $*"
    if [ "$apt_updated" = 0 ]; then as_root apt-get update -qq; apt_updated=1; fi
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}
# The candidate version apt would install of a package, or nothing.
apt_candidate() { apt-cache policy "$1" 2>/dev/null | awk '/Candidate:/ && $2 != "(none)" {print $2}'; }

# QGIS's GEOS (the system's), or nothing when QGIS's Python bindings are missing
qgis_geos() { "$SYS_PY" -c 'from qgis.core import Qgis; print(Qgis.geosVersion().split("-")[0])' 2>/dev/null || true; }

need_apt=()
QGIS_GEOS="$(qgis_geos)"
[ -n "$QGIS_GEOS" ] || need_apt+=(qgis python3-qgis qgis-providers)
"$SYS_PY" -c 'from osgeo import gdal' 2>/dev/null || need_apt+=(python3-gdal)
command -v gdal_translate >/dev/null || need_apt+=(gdal-bin)
command -v qgis_process.bin >/dev/null || need_apt+=(qgis-providers)
command -v xmllint >/dev/null || need_apt+=(libxml2-utils)
command -v lrelease >/dev/null || need_apt+=(qttools5-dev-tools)
command -v Xvfb >/dev/null || need_apt+=(xvfb)  # the real QGIS window in tests and screenshots
command -v git >/dev/null || need_apt+=(git)  # the tests copy the checkout's files (scripts/qgis-chroot.sh)
[ -d /usr/share/fonts/truetype/nanum ] || need_apt+=(fonts-nanum)  # Korean labels render as boxes without
# meshoptimizer (the 3D Tiles web profile) is built from source: a C++ compiler and Python's headers
command -v g++ >/dev/null || need_apt+=(g++)
[ -f "$("$SYS_PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')/Python.h" ] || need_apt+=(python3-dev)
"$SYS_PY" -c 'import venv, ensurepip' 2>/dev/null || need_apt+=(python3-venv)
# PostgreSQL driver for PostGIS colour stores: Debian's python3-psycopg2 (python3-qgis depends on
# it; built on Debian's libpq), not a pip wheel bundling its own libpq. The server itself is only
# needed by the tests (scripts/test.sh starts it with scripts/postgis.sh).
"$SYS_PY" -c 'import psycopg2' 2>/dev/null || need_apt+=(python3-psycopg2)
[ ${#need_apt[@]} -eq 0 ] || apt_install "${need_apt[@]}"

# shapely inside QGIS must use QGIS's GEOS: QGIS exports the system GEOS's symbols globally, and a
# shapely wheel's bundled GEOS then resolves to them and crashes QGIS (segfault). The platform's
# python3-shapely is used when it is shapely 2 on the same GEOS (Debian trixie/sid); else shapely is
# built from source against the system GEOS. Checked by feature: Debian's says "0+unknown".
[ -n "$QGIS_GEOS" ] || QGIS_GEOS="$(qgis_geos)"
platform_shapely_fits() {
    "$SYS_PY" - "$QGIS_GEOS" <<'EOF' 2>/dev/null
import sys
import shapely
api = all(hasattr(shapely, name) for name in ("from_wkb", "to_wkb", "make_valid", "STRtree", "geos_version"))
same_geos = ".".join(map(str, shapely.geos_version)) == sys.argv[1]
sys.exit(0 if api and same_geos and shapely.__file__.startswith("/usr/lib/") else 1)
EOF
}
# The choice is kept in the venv (asking apt takes seconds); "platform" is checked again each time.
CHOICE="$VENV/.wit-shapely"
SHAPELY="$(cat "$CHOICE" 2>/dev/null || true)"
if [ "$SHAPELY" = "platform $QGIS_GEOS" ] && platform_shapely_fits; then
    SHAPELY=platform
elif [ "$SHAPELY" = "source $QGIS_GEOS" ]; then
    SHAPELY=source
else
    candidate="$(apt_candidate python3-shapely)"
    if ! platform_shapely_fits && [ "${candidate%%.*}" -ge 2 ] 2>/dev/null \
        && ! dpkg-query -W -f '${Status}' python3-shapely 2>/dev/null | grep -q 'ok installed'; then
        apt_install python3-shapely  # shapely 2 from the platform (checked against QGIS's GEOS next)
    fi
    if platform_shapely_fits; then SHAPELY=platform; else SHAPELY=source; fi
fi
if [ "$SHAPELY" = source ]; then
    build_apt=()
    command -v geos-config >/dev/null || build_apt+=(libgeos-dev)
    command -v pkg-config >/dev/null || build_apt+=(pkg-config)  # shapely's build finds GEOS with it
    command -v cc >/dev/null || build_apt+=(build-essential)
    [ -f "$("$SYS_PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')/Python.h" ] \
        || build_apt+=(python3-dev)
    [ ${#build_apt[@]} -eq 0 ] || apt_install "${build_apt[@]}"
fi

# Python environment: QGIS's interpreter, system site-packages visible (qgis, osgeo, numpy, and
# shapely when the platform's fits).
if [ ! -x "$VENV/bin/python" ]; then
    log "creating $VENV"
    "$SYS_PY" -m venv --system-site-packages "$VENV"
fi
# numpy is the platform's (osgeo.gdal_array and QGIS are built against it): the constraint keeps pip
# from installing another one into the venv.
NUMPY_VERSION="$("$SYS_PY" -c 'import numpy; print(numpy.__version__)')"
STAMP="$VENV/.wit-requirements"
TRIANGLE="${WIT_TRIANGLE:-1}"
WANT="$(cat requirements.txt requirements-dev.txt
        echo "numpy==$NUMPY_VERSION shapely=$SHAPELY geos=$QGIS_GEOS triangle=$TRIANGLE")"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$WANT" ]; then
    log "installing Python packages (the platform's numpy $NUMPY_VERSION, shapely: $SHAPELY)"
    printf 'numpy==%s\n' "$NUMPY_VERSION" > "$VENV/constraints.txt"
    # requirements-dev.txt (which includes requirements.txt) without shapely when the platform's is
    # used, and without triangle, installed below
    { grep -v '^-r ' requirements-dev.txt; cat requirements.txt; } \
        | grep -Ev '^\s*(triangle|triangle3)\b' \
        | { if [ "$SHAPELY" = platform ]; then grep -Ev '^\s*(shapely\b|--no-binary shapely)'; else cat; fi; } \
        > "$VENV/requirements-setup.txt"
    "$VENV/bin/python" -m pip install -q --disable-pip-version-check -c "$VENV/constraints.txt" \
        -r "$VENV/requirements-setup.txt"
    if [ "$SHAPELY" = platform ] && [ -n "$(compgen -G "$VENV/lib/python3*/site-packages/shapely")" ]; then
        "$VENV/bin/python" -m pip uninstall -q -y shapely  # an earlier build would hide the platform's
    fi
    # triangle: J. R. Shewchuk's Triangle as the module `triangle`, from the `triangle` wheels (none
    # for Python 3.14 yet) or `triangle3` (the same module, wheels for 3.11-3.14), else built
    if [ "$TRIANGLE" = 0 ]; then
        "$VENV/bin/python" -m pip uninstall -q -y triangle triangle3 2>/dev/null || true
    elif ! "$VENV/bin/python" -c 'import triangle' 2>/dev/null; then
        for requirement in "triangle>=20230923" "triangle3"; do
            "$VENV/bin/python" -m pip install -q --disable-pip-version-check --only-binary :all: \
                "$requirement" 2>/dev/null && break
        done
        "$VENV/bin/python" -c 'import triangle' 2>/dev/null \
            || "$VENV/bin/python" -m pip install -q --disable-pip-version-check "triangle>=20230923"
    fi
    printf '%s' "$WANT" > "$STAMP"
fi
printf '%s %s' "$SHAPELY" "$QGIS_GEOS" > "$CHOICE"

# Translations: .ts (source, committed) -> .qm (compiled, ignored by git).
shopt -s nullglob
for ts in i18n/*.ts; do
    qm="${ts%.ts}.qm"
    if [ ! -f "$qm" ] || [ "$ts" -nt "$qm" ]; then
        lrelease -silent "$ts" -qm "$qm"
    fi
done
# The plugin's byte-code, as a Python allowed to write it keeps it after a first run: where
# PYTHONDONTWRITEBYTECODE is set (this machine's shells), every qgis_process run and each step's process
# would compile the core again (0.4 s in QGIS alone). compileall rewrites only what changed.
"$VENV/bin/python" -m compileall -q wit_plugin processing_provider __init__.py >/dev/null
# The web viewer and the browser tests: Node.js, Chromium, the pinned npm packages (viewer/).
[ "${WIT_SETUP_VIEWER:-1}" = 0 ] || bash scripts/setup-viewer.sh
[ "$did" = 0 ] || printf '[setup] ready\n' >&2
