#!/usr/bin/env bash
# make demo: the main job on the embedded default data (scripts/demo.py), results in out/demo/.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
source "$ROOT/scripts/env.sh"
exec "$ROOT/.venv/bin/python" "$ROOT/scripts/demo.py" "$@"
