#!/usr/bin/env bash
# Lint (make test runs it before pytest): ruff check of the whole project, configured in pyproject.toml
# (pycodestyle, pyflakes, import order, bugbear, pyupgrade; 120 columns). ARGS: other ruff check options or
# paths (e.g. --fix, or one file).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
exec .venv/bin/python -m ruff check "${@:-.}"
