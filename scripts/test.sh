#!/usr/bin/env bash
# The whole test suite (make test): set-up, then pytest with QGIS headless in a throwaway profile.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
source "$ROOT/scripts/env.sh"
QGIS_CUSTOM_CONFIG_PATH="$(mktemp -d)"
export QGIS_CUSTOM_CONFIG_PATH
trap 'rm -rf "$QGIS_CUSTOM_CONFIG_PATH"' EXIT
cd "$ROOT"
.venv/bin/python -m pytest "$@"
