#!/usr/bin/env bash
# make bench: the paper's Tables 15, 16, 19 and 20 with our figures beside them (benchmarks/run_all.py).
# Options pass through, e.g. `bash scripts/bench.sh --quick` or `--sizes default --runs 3`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
source scripts/env.sh
exec .venv/bin/python benchmarks/run_all.py "$@"
