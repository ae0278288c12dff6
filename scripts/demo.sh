#!/usr/bin/env bash
# make demo: the main job on the embedded default data, through qgis_process like a batch user.
# Default sample: 1 km around Suseo station. Results under out/demo/.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${WIT_DEMO_OUT:-$ROOT/out/demo}"
QP="$ROOT/scripts/qgis-process"
mkdir -p "$OUT"
step() { printf '\n== %s\n' "$*"; }
timed() { local t0=$SECONDS; "$@"; printf '   (%d s)\n' $((SECONDS - t0)); }

step "1. sample data: 1 km around Suseo station (wit:generatesample)"
timed "$QP" run wit:generatesample --RADIUS=1000 --SEED=42 --OUTPUT="$OUT/sample" >"$OUT/generatesample.log"
tail -n +1 "$OUT/generatesample.log" | grep -E '^(BUILDINGS_WRITTEN|TILES_WRITTEN|BUILDINGS|ROADS|DISTRICTS|DEM|ORTHO_FOLDER):' | sed 's/^/   /'

step "done: results in $OUT"
