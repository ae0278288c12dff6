#!/usr/bin/env bash
# The test suite (make test): set-up, then pytest with QGIS headless in a throwaway profile.
#   bash scripts/test.sh             the whole suite, quickest verdicts first: ruff and the security scan
#                                    (scripts/lint.sh), then the fast core tests as --core -m "not slow" runs
#                                    them (about a minute), then the rest on this machine's QGIS
#                                    (-m "qgis or slow": the complement, so no test runs twice), then the
#                                    QGIS-facing tests (pytest marker qgis_facing) on QGIS 3.44 LTR in a Debian sid
#                                    chroot (scripts/qgis-chroot.sh; WIT_TEST_CHROOT=0 leaves that out); each
#                                    stage's verdict counts, the later stages run anyway
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
QGIS_CUSTOM_CONFIG_PATH="$(mktemp -d)"
export QGIS_CUSTOM_CONFIG_PATH
trap 'rm -rf "$QGIS_CUSTOM_CONFIG_PATH"' EXIT
cd "$ROOT"

core_pytest() {  # pytest without QGIS: qgis unimportable, pytest-qgis off (its ini option then unknown)
    PYTHONPATH="$ROOT/tests/without_qgis:$PYTHONPATH" .venv/bin/python -m pytest \
        -p no:pytest_qgis -W ignore::pytest.PytestConfigWarning "$@"
}

if [ "${1:-}" = --core ]; then
    shift
    core_pytest "$@"
    exit
fi
if [ $# -gt 0 ]; then
    .venv/bin/python -m pytest "$@"
    exit
fi
status=0
bash scripts/lint.sh || status=$?
echo "[test] the fast core tests (--core -m 'not slow')" >&2
start=$SECONDS
core_pytest -m "not slow" || status=$?
core_seconds=$((SECONDS - start))
echo "[test] the rest on this machine's QGIS (-m 'qgis or slow')" >&2
QGIS_VERSION="$(/usr/bin/python3 -c 'from qgis.core import Qgis; print(Qgis.QGIS_VERSION)' 2>/dev/null)"
start=$SECONDS
.venv/bin/python -m pytest -m "qgis or slow" || status=$?
host_seconds=$((SECONDS - start))
printf '[test] fast core tests: %d s; the rest on QGIS %s (this machine): %d s\n' \
    "$core_seconds" "$QGIS_VERSION" "$host_seconds" >&2
[ "${WIT_TEST_CHROOT:-1}" != 0 ] || exit "$status"
start=$SECONDS
bash scripts/qgis-chroot.sh test || status=$?
printf '[test] QGIS-facing tests in the chroot (build included): %d s\n' "$((SECONDS - start))" >&2
exit "$status"
