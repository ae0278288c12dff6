#!/usr/bin/env bash
# The whole test suite (make test): set-up, then pytest with QGIS headless in a throwaway profile.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
source "$ROOT/scripts/env.sh"
# The colour store's PostGIS tests use a real local server (installed and started here; they fail,
# never skip, when it cannot start).
bash "$ROOT/scripts/postgis.sh" >/dev/null || echo "[test] WARNING: no PostgreSQL + PostGIS server" >&2
QGIS_CUSTOM_CONFIG_PATH="$(mktemp -d)"
export QGIS_CUSTOM_CONFIG_PATH
trap 'rm -rf "$QGIS_CUSTOM_CONFIG_PATH"' EXIT
cd "$ROOT"
.venv/bin/python -m pytest "$@"
