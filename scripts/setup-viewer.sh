#!/usr/bin/env bash
# Idempotent set-up of the web viewer and the browser tests (called by scripts/setup.sh): Node.js and
# npm, Debian's Chromium (headless, for the tests and the benchmark), and the npm packages pinned in
# viewer/package-lock.json (CesiumJS, the Khronos glTF validator, playwright-core) installed into
# viewer/node_modules — project-local, ignored by git, left out of the plugin zip. The plugin itself
# needs none of this. Without access to the npm registry the step warns and the rest still works.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT/viewer"
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

need_apt=()
command -v node >/dev/null || need_apt+=(nodejs)
command -v npm >/dev/null || need_apt+=(npm)
[ -x /usr/bin/chromium ] || need_apt+=(chromium)
if [ ${#need_apt[@]} -gt 0 ]; then
    printf '[setup] installing system packages: %s\n' "${need_apt[*]}" >&2
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

STAMP=node_modules/.wit-package-lock
if [ ! -f "$STAMP" ] || ! cmp -s package-lock.json "$STAMP"; then
    printf '[setup] installing the viewer packages (npm ci in viewer/)\n' >&2
    if npm ci --no-audit --no-fund --ignore-scripts --loglevel=error >/dev/null; then
        cp package-lock.json "$STAMP"
    else
        printf '[setup] WARNING: npm ci failed (no access to the npm registry?): no web viewer, and the\n' >&2
        printf '[setup]          browser and glTF tests will fail until `make setup` runs with access.\n' >&2
    fi
fi
