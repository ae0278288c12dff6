#!/usr/bin/env bash
# The test suite (make test): set-up, then pytest with QGIS headless in a throwaway profile.
#   bash scripts/test.sh             the whole suite on this machine's QGIS, then the QGIS-facing tests
#                                    (pytest marker qgis_facing) on QGIS 3.44 LTR in a Debian sid chroot
#                                    (scripts/qgis-chroot.sh; WIT_TEST_CHROOT=0 leaves that out);
#                                    ruff first (scripts/lint.sh: its verdict counts, the tests run anyway)
#   bash scripts/test.sh ARGS...     pytest ARGS on this machine's QGIS only
#   bash scripts/test.sh --core ARGS...  the core tests only (marker qgis deselected), with qgis and
#                                    processing unimportable (tests/without_qgis), the pytest-qgis plugin off:
#                                    proof that they need no QGIS (make test-fast: --core -m "not slow"); name
#                                    core test files only (a file named on the command line is always imported)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup.sh"
source "$ROOT/scripts/env.sh"
# The colour store's PostGIS tests use a real local server (installed and started here; they fail,
# never skip, when it cannot start). In the QGIS-version chroot the host's server is used
# (WIT_TEST_POSTGIS_DSN): both share the network, and port 5432 is the host's.
if [ -z "${WIT_TEST_POSTGIS_DSN:-}" ]; then
    WIT_TEST_POSTGIS_DSN="$(bash "$ROOT/scripts/postgis.sh")" \
        || echo "[test] WARNING: no PostgreSQL + PostGIS server" >&2
    [ -z "$WIT_TEST_POSTGIS_DSN" ] || export WIT_TEST_POSTGIS_DSN
fi
if [ "${1:-}" = --core ]; then
    shift
    export PYTHONPATH="$ROOT/tests/without_qgis:$PYTHONPATH"
    set -- -p no:pytest_qgis -W ignore::pytest.PytestConfigWarning "$@"  # (its ini option, unknown without it)
fi
QGIS_CUSTOM_CONFIG_PATH="$(mktemp -d)"
export QGIS_CUSTOM_CONFIG_PATH
trap 'rm -rf "$QGIS_CUSTOM_CONFIG_PATH"' EXIT
cd "$ROOT"
lint=0
[ $# -gt 0 ] || bash scripts/lint.sh || lint=$?
if [ $# -gt 0 ] || [ "${WIT_TEST_CHROOT:-1}" = 0 ]; then
    .venv/bin/python -m pytest "$@" || exit
    exit "$lint"
fi
status=$lint
QGIS_VERSION="$(/usr/bin/python3 -c 'from qgis.core import Qgis; print(Qgis.QGIS_VERSION)' 2>/dev/null)"
start=$SECONDS
.venv/bin/python -m pytest || status=$?
host_seconds=$((SECONDS - start))
start=$SECONDS
bash scripts/qgis-chroot.sh test || status=$?
printf '[test] QGIS %s (this machine, whole suite): %d s; QGIS-facing tests in the chroot (build included): %d s\n' \
    "$QGIS_VERSION" "$host_seconds" "$((SECONDS - start))" >&2
exit "$status"
