#!/usr/bin/env bash
# Screenshots of the plugin's Processing dialog in the real QGIS window, English and Korean:
#   docs/qgis_dialog_en.png, docs/qgis_dialog_ko.png   the dialog alone (Qt grab)
#   out/screenshot/window_<lang>.png                   QGIS's main window with the dialog (Qt grab)
#   out/screenshot/screen_<lang>.png                   the whole X screen (xwd), proof QGIS ran
#   out/screenshot/dialog_<lang>.json                  title and labels the dialog showed
# Starts its own Xvfb (a free display number), a throwaway profile per language with the plugin
# linked in as wit_citymodel and enabled, runs `qgis --code scripts/screenshot_dialog.py`, stops
# Xvfb. Idempotent. Exits non-zero if a screenshot is missing or the Korean dialog shows no Korean.
#   WIT_SHOT_ALGS=wit:citymodel,wit:preparevectors   algorithms to try, first registered wins
#   WIT_SHOT_LANGS="en ko"                            which locales
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh >/dev/null
export QT_QPA_PLATFORM=xcb
source scripts/env.sh

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
need_apt=()
command -v Xvfb >/dev/null || need_apt+=(xvfb)
command -v xwd >/dev/null || need_apt+=(x11-apps)
command -v xwdtopnm >/dev/null || need_apt+=(netpbm)
# Hangul glyphs: without a Korean font the Korean dialog shows boxes
fc-list :lang=ko family | grep -q . || need_apt+=(fonts-nanum)
if [ ${#need_apt[@]} -gt 0 ]; then
    echo "[screenshot] installing ${need_apt[*]}" >&2
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

OUT="$ROOT/out/screenshot"
mkdir -p "$OUT" docs
export WIT_SHOT_ALGS="${WIT_SHOT_ALGS:-wit:citymodel,wit:preparevectors}"

XVFB_PID=""
cleanup() { [ -z "$XVFB_PID" ] || kill "$XVFB_PID" 2>/dev/null || true; }
trap cleanup EXIT
: > "$OUT/display"
Xvfb -displayfd 3 -screen 0 1600x1000x24 -nolisten tcp 3>"$OUT/display" 2>"$OUT/xvfb.log" &
XVFB_PID=$!
for _ in $(seq 100); do [ -s "$OUT/display" ] && break; sleep 0.1; done
[ -s "$OUT/display" ] || { echo "[screenshot] Xvfb did not start (see $OUT/xvfb.log)" >&2; exit 1; }
export DISPLAY=":$(tr -dc 0-9 < "$OUT/display")"

status=0
for lang in ${WIT_SHOT_LANGS:-en ko}; do
    case "$lang" in en) locale=en_US ;; ko) locale=ko_KR ;; *) locale="$lang" ;; esac
    profile="$OUT/profile-$lang"
    rm -rf "$profile"
    mkdir -p "$profile/profiles/default/python/plugins" "$profile/profiles/default/QGIS"
    ln -s "$ROOT" "$profile/profiles/default/python/plugins/wit_citymodel"
    cat > "$profile/profiles/default/QGIS/QGIS3.ini" <<EOF
[PythonPlugins]
wit_citymodel=true
processing=true

[locale]
overrideFlag=true
userLocale=$locale
globalLocale=$locale

[qgis]
checkVersion=false

[core]
NewsFeed\\httpsfeedqgisorg\\disabled=true
EOF
    dialog_png="$OUT/dialog_$lang.png" json="$OUT/dialog_$lang.json"
    rm -f "$dialog_png" "$json" "$OUT/window_$lang.png" "$OUT/screen_$lang.xwd" "$OUT/screen_$lang.png"
    echo "[screenshot] $lang: QGIS on $DISPLAY" >&2
    rc=0
    QGIS_CUSTOM_CONFIG_PATH="$profile" LANG="$locale.UTF-8" \
        WIT_SHOT_DIALOG="$dialog_png" WIT_SHOT_WINDOW="$OUT/window_$lang.png" \
        WIT_SHOT_SCREEN="$OUT/screen_$lang.xwd" WIT_SHOT_JSON="$json" \
        timeout 180 qgis --nologo --noversioncheck --code "$ROOT/scripts/screenshot_dialog.py" \
        >"$OUT/qgis_$lang.log" 2>&1 || rc=$?
    if [ -s "$OUT/screen_$lang.xwd" ]; then
        xwdtopnm "$OUT/screen_$lang.xwd" 2>/dev/null | pnmtopng > "$OUT/screen_$lang.png" 2>/dev/null \
            && rm -f "$OUT/screen_$lang.xwd"
    fi
    if [ ! -s "$dialog_png" ]; then
        echo "[screenshot] $lang: no dialog screenshot (QGIS exit $rc, see $OUT/qgis_$lang.log)" >&2
        status=1
        continue
    fi
    cp "$dialog_png" "docs/qgis_dialog_$lang.png"
    size=$(stat -c %s "docs/qgis_dialog_$lang.png")
    if [ "$size" -ge 409600 ]; then
        echo "[screenshot] $lang: docs/qgis_dialog_$lang.png is $size bytes (>= 400 KB)" >&2
        status=1
    fi
    if [ "$lang" = ko ] && ! grep -qP '[\x{AC00}-\x{D7A3}]' "$json"; then
        echo "[screenshot] ko: the dialog shows no Hangul (see $json)" >&2
        status=1
    fi
    echo "[screenshot] $lang: docs/qgis_dialog_$lang.png ($size bytes), $(python3 -c \
        'import json,sys; d=json.load(open(sys.argv[1])); print(d["algorithm"], "-", d["window_title"])' "$json")" >&2
done
exit "$status"
