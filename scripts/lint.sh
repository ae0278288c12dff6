#!/usr/bin/env bash
# Lint (make lint; make test runs it before pytest):
#   1. ruff check of the whole project, configured in pyproject.toml (pycodestyle, pyflakes, import order,
#      bugbear, pyupgrade; 120 columns);
#   2. mypy, the type check of the core (wit_plugin/), configured in pyproject.toml;
#   3. the security scan plugins.qgis.org runs on every upload (Bandit and detect-secrets, its settings), on
#      exactly what the plugin ZIP ships (scripts/security_scan.py builds one in a temporary folder).
# Fails when any finds something. ARGS: other ruff check options or paths (e.g. --fix, or one file): then
# ruff only.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
if [ $# -gt 0 ]; then
    exec .venv/bin/python -m ruff check "$@"
fi
status=0
.venv/bin/python -m ruff check . || status=$?
.venv/bin/python -m mypy || status=$?
.venv/bin/python scripts/security_scan.py || status=$?
exit "$status"
