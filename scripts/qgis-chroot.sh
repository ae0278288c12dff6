#!/usr/bin/env bash
# Another QGIS for the tests: a Debian chroot holding its distribution's QGIS, built once with
# debootstrap and cached outside the clone; the checkout is copied in and run there.
#
#   scripts/qgis-chroot.sh build            # build the chroot if it is missing, half-built or stale
#   scripts/qgis-chroot.sh test [ARGS]      # the QGIS-facing tests (pytest -m qgis_facing) in it
#   scripts/qgis-chroot.sh run CMD [ARGS]   # any command in the copied checkout, e.g. `make demo`
#   scripts/qgis-chroot.sh delete           # unmount and delete the chroot
#
# Default: Debian sid (QGIS 3.44 LTR today) in /var/cache/wit-citymodel/chroots/sid-qgis.
# WIT_CHROOT_SUITE (sid), WIT_CHROOT_PACKAGES ("qgis python3-qgis qgis-providers"),
# WIT_CHROOT_APT_TARGET (e.g. bookworm-backports, then added to the sources and installed from)
# and WIT_CHROOT_DIR (the chroot's folder) choose another. Needs root (debootstrap, chroot, mount).
#
# The build happens in DIR.partial and is renamed to DIR only when it finished, with a stamp
# (DIR/etc/wit-chroot-stamp) recording what was asked for; a partial build, a missing stamp or a
# stamp that differs from the request is deleted and built again. /proc, /dev and /sys are mounted
# for a run only and unmounted on exit, whatever happens; a chroot is deleted only after all its
# mounts are gone, with `rm --one-file-system`. Runs on one chroot are serialised by a lock.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SUITE="${WIT_CHROOT_SUITE:-sid}"
PACKAGES="${WIT_CHROOT_PACKAGES:-qgis python3-qgis qgis-providers}"
APT_TARGET="${WIT_CHROOT_APT_TARGET:-}"
DIR="${WIT_CHROOT_DIR:-/var/cache/wit-citymodel/chroots/$SUITE-qgis}"
RECIPE=3  # bump when the build steps below change: chroots built by an older recipe are rebuilt
CHECKOUT=/srv/wit/checkout  # inside the chroot: the copy of this checkout
SHARED=/srv/wit/shared      # inside the chroot: ../shared (read-only) when the checkout has one
STAMP_FILE=etc/wit-chroot-stamp
log() { printf '[chroot] %s\n' "$*" >&2; }
[ "$(id -u)" = 0 ] || { log "needs root (debootstrap, chroot, mount)"; exit 1; }

# The Debian mirror this machine's apt uses (deb822 or one-line sources), else deb.debian.org.
host_mirror() {
    local uri
    uri="$(cat /etc/apt/sources.list.d/*.sources 2>/dev/null \
        | awk '/^URIs:/ {u = $2} /^Suites:/ && / (bookworm|trixie|forky|sid|stable|testing|unstable)( |$)/ {print u; exit}')"
    [ -n "$uri" ] || uri="$(grep -hE '^deb +(\[[^]]*\] +)?https?://' /etc/apt/sources.list 2>/dev/null \
        | grep -v security | awk '{for (i = 2; i <= NF; i++) if ($i ~ /^http/) {print $i; exit}}' | head -n1)"
    printf '%s' "${uri:-http://deb.debian.org/debian}"
}
MIRROR="${WIT_CHROOT_MIRROR:-$(host_mirror)}"
WANT="recipe=$RECIPE suite=$SUITE mirror=$MIRROR target=${APT_TARGET:-default} packages=$PACKAGES"

mounts_under() { awk -v d="$1" '$2 == d || index($2, d "/") == 1 {print $2}' /proc/self/mounts | sort -r; }

unmount_all() {
    local mnt
    for mnt in $(mounts_under "$1"); do
        umount "$mnt" 2>/dev/null || umount -l "$mnt"
    done
}

delete_chroot() {
    [ -e "$1" ] || return 0
    unmount_all "$1"
    if [ -n "$(mounts_under "$1")" ]; then
        log "still mounted under $1: not deleting it"
        return 1
    fi
    rm -rf --one-file-system "$1"
}

install_host_tools() {
    local need=()
    command -v debootstrap >/dev/null || need+=(debootstrap)
    command -v rsync >/dev/null || need+=(rsync)
    [ ${#need[@]} -eq 0 ] && return 0
    log "installing ${need[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
}

# What a run needs from the host: name resolution, the CA bundle (the registries may be reached
# through a TLS proxy whose CA only the host knows) and the pip and npm settings.
copy_host_settings() {
    local dir="$1" file
    cp -L /etc/resolv.conf "$dir/etc/resolv.conf" 2>/dev/null || true
    cp /etc/hosts "$dir/etc/hosts"
    if compgen -G '/usr/local/share/ca-certificates/*' >/dev/null; then
        mkdir -p "$dir/usr/local/share/ca-certificates"
        cp -r /usr/local/share/ca-certificates/. "$dir/usr/local/share/ca-certificates/"
    fi
    mkdir -p "$dir/etc/ssl/certs"
    [ ! -f /etc/ssl/certs/ca-certificates.crt ] || cp /etc/ssl/certs/ca-certificates.crt "$dir/etc/ssl/certs/"
    [ ! -f /etc/pip.conf ] || cp /etc/pip.conf "$dir/etc/pip.conf"
    for file in .config/pip/pip.conf .npmrc; do
        if [ -f "$HOME/$file" ]; then
            mkdir -p "$(dirname "$dir/root/$file")"
            cp "$HOME/$file" "$dir/root/$file"
        fi
    done
}

# /proc, /sys, /dev (with its own pts and shm) in the chroot until this shell exits.
mount_run() {
    MOUNTED_DIR="$1"
    trap 'unmount_all "$MOUNTED_DIR"' EXIT
    trap 'exit 130' INT TERM
    mount -t proc proc "$1/proc"
    mount -t sysfs sysfs "$1/sys"
    mount --bind /dev "$1/dev"
    mount -t devpts -o newinstance,ptmxmode=0666 devpts "$1/dev/pts"
    mount -t tmpfs -o mode=1777 tmpfs "$1/dev/shm"
}

in_chroot() {
    chroot "$1" /usr/bin/env -i HOME=/root TERM="${TERM:-dumb}" LANG=C.UTF-8 CI="${CI:-}" \
        PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "${@:2}"
}

build() {
    if [ -f "$DIR/$STAMP_FILE" ] && [ "$(cat "$DIR/$STAMP_FILE")" = "$WANT" ]; then
        return 0
    fi
    install_host_tools
    if [ -e "$DIR" ]; then
        log "$DIR is half-built or was built for something else: building it again"
        delete_chroot "$DIR"
    fi
    local partial="$DIR.partial" start=$SECONDS debootstrap_log
    delete_chroot "$partial"
    mkdir -p "$(dirname "$DIR")"
    debootstrap_log="$(dirname "$DIR")/$(basename "$DIR").debootstrap.log"
    log "debootstrap $SUITE from $MIRROR into $partial"
    # The mirror may serve a Release file past its Valid-Until date: debootstrap does not check
    # that date, and apt is told not to below.
    debootstrap --variant=minbase --include=ca-certificates "$SUITE" "$partial" "$MIRROR" \
        >"$debootstrap_log" 2>&1 \
        || { tail -n 20 "$debootstrap_log" >&2; log "debootstrap failed (log: $debootstrap_log)"; exit 1; }
    log "debootstrap: $((SECONDS - start)) s"
    cat >"$partial/etc/apt/apt.conf.d/90wit" <<'EOF'
Acquire::Check-Valid-Until "false";
APT::Install-Recommends "false";
EOF
    if [ -n "$APT_TARGET" ]; then
        echo "deb $MIRROR $APT_TARGET main" >"$partial/etc/apt/sources.list.d/$APT_TARGET.list"
    fi
    # no service may start inside the chroot: it shares the host's network and ports
    printf '#!/bin/sh\nexit 101\n' >"$partial/usr/sbin/policy-rc.d"
    chmod +x "$partial/usr/sbin/policy-rc.d"
    copy_host_settings "$partial"
    (
        mount_run "$partial"
        in_chroot "$partial" update-ca-certificates >/dev/null 2>&1 || true
        in_chroot "$partial" apt-get update -qq
        log "installing $PACKAGES${APT_TARGET:+ from $APT_TARGET}"
        # shellcheck disable=SC2086  # PACKAGES is a list
        in_chroot "$partial" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
            ${APT_TARGET:+-t "$APT_TARGET"} $PACKAGES >/dev/null
        in_chroot "$partial" apt-get clean
    )
    printf '%s' "$WANT" >"$partial/$STAMP_FILE"
    mv "$partial" "$DIR"
    log "built $DIR in $((SECONDS - start)) s: QGIS $(in_chroot "$DIR" dpkg-query -W -f '${Version}' qgis-providers)"
}

# The checkout copied to CHECKOUT in the chroot, less what git ignores (.venv, outputs, node_modules,
# compiled translations): the chroot keeps its own of those between runs.
sync_checkout() {
    mkdir -p "$DIR$CHECKOUT" "$DIR$SHARED"
    # byte-code caches go first: ignored, rsync would keep them, and with them a package moved away
    # (a folder holding only __pycache__ imports as a namespace package)
    find "$DIR$CHECKOUT" \( -path "$DIR$CHECKOUT/.venv" -o -path "$DIR$CHECKOUT/viewer/node_modules" \) -prune \
        -o -type d -name __pycache__ -exec rm -rf {} +
    rsync -a --delete --exclude=/.git --filter=':- .gitignore' "$ROOT/" "$DIR$CHECKOUT/"
}

run_in_checkout() {
    build
    install_host_tools
    copy_host_settings "$DIR"
    sync_checkout
    mount_run "$DIR"
    if [ -d "$ROOT/../shared" ]; then
        mount --bind "$ROOT/../shared" "$DIR$SHARED"
        mount -o remount,bind,ro "$DIR$SHARED"
    fi
    in_chroot "$DIR" bash -c 'cd "$0" && exec "$@"' "$CHECKOUT" "$@"
}

# A new user's QGIS has no pip (Debian's QGIS does not pull python3-pip), so the ZIP-install test must get pip
# the way wit:installdependencies does, from pip's own wheel: a python3-pip left in the chroot (an earlier
# version of that test installed it, as the message said then) is removed before the tests.
WITHOUT_SYSTEM_PIP='if dpkg-query -W -f "\${Status}" python3-pip 2>/dev/null | grep -q "ok installed"; then
    echo "[chroot] removing python3-pip: a new user'"'"'s QGIS has no pip" >&2
    DEBIAN_FRONTEND=noninteractive apt-get purge -y -qq python3-pip >/dev/null
fi'

# one user of a chroot at a time (a build or a run)
mkdir -p "$(dirname "$DIR")"
exec 9>"$DIR.lock"
flock 9

case "${1:-}" in
    build) build ;;
    run) shift; run_in_checkout "$@" ;;
    test)
        shift
        # the host's PostgreSQL serves the colour store's tests: a second server cannot have port 5432
        dsn="${WIT_TEST_POSTGIS_DSN:-$(bash "$ROOT/scripts/postgis.sh")}"
        run_in_checkout env WIT_TEST_POSTGIS_DSN="$dsn" bash -c "$WITHOUT_SYSTEM_PIP"'
            exec bash scripts/test.sh -m qgis_facing "$@"' bash "$@"
        ;;
    delete) delete_chroot "$DIR"; delete_chroot "$DIR.partial" ;;
    *) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 2 ;;
esac
