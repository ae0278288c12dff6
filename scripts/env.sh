# Sourced by the project's scripts: the environment QGIS, GDAL and PROJ need here, headless.
WIT_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PROJ_DATA="${PROJ_DATA:-/usr/share/proj}"
export QT_QPA_PLATFORM="${QT_QPA_PLATFORM:-offscreen}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/runtime-$(id -un)}"
mkdir -p -m 700 "$XDG_RUNTIME_DIR"
# Python packages of .venv (pythoncdt, triangle, shapely 2) importable by QGIS's own /usr/bin/python3.
WIT_SITE="$("$WIT_ROOT/.venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
export PYTHONPATH="$WIT_SITE${PYTHONPATH:+:$PYTHONPATH}"
