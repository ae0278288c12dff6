#!/usr/bin/env bash
# Idempotent: a real local PostgreSQL + PostGIS server for the colour store's tests (the colour store
# writes to PostGIS, so its tests run against a real server, never a mock).
# Installs Debian's packages if missing, starts the cluster if it is down, creates the role `wit`
# (password `wit`, TCP login on 127.0.0.1) and the database `wit_test` with the postgis extension,
# then prints the DSN on stdout. When all that is already in place it costs one psql call.
# Override with WIT_PG_VERSION (default 15, Debian 12's).
set -euo pipefail
PG_VERSION="${WIT_PG_VERSION:-15}"
ROLE=wit PASSWORD=wit DB=wit_test
# Only the DSN goes to stdout (callers capture it): everything else the tools print goes to stderr
# (pg_ctlcluster says "Removed stale pid file." on stdout after an unclean stop).
exec 3>&1 1>&2
log() { printf '[postgis] %s\n' "$*" >&2; }
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
as_postgres() { if [ "$(id -u)" = 0 ]; then runuser -u postgres -- "$@"; else sudo -u postgres "$@"; fi; }
port() { pg_lsclusters -h 2>/dev/null | awk -v v="$PG_VERSION" '$1 == v && $2 == "main" {print $3}'; }
dsn() { printf 'postgresql://%s:%s@127.0.0.1:%s/%s' "$ROLE" "$PASSWORD" "$(port)" "$DB"; }

# Fast path: everything is already up.
if command -v psql >/dev/null && [ -n "$(port)" ] \
    && PGCONNECT_TIMEOUT=3 psql "$(dsn)" -XtAqc 'SELECT postgis_lib_version()' >/dev/null 2>&1; then
    { dsn; echo; } >&3
    exit 0
fi

need=()
command -v pg_ctlcluster >/dev/null || need+=(postgresql-common)
[ -x "/usr/lib/postgresql/$PG_VERSION/bin/postgres" ] || need+=("postgresql-$PG_VERSION")
[ -f "/usr/share/postgresql/$PG_VERSION/extension/postgis.control" ] || need+=("postgresql-$PG_VERSION-postgis-3")
command -v psql >/dev/null || need+=("postgresql-client-$PG_VERSION")
if [ ${#need[@]} -gt 0 ]; then
    log "installing ${need[*]}"
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi
if [ -z "$(port)" ]; then
    log "creating cluster $PG_VERSION/main"
    as_root pg_createcluster "$PG_VERSION" main >/dev/null
fi
if ! pg_lsclusters -h | awk -v v="$PG_VERSION" '$1 == v && $2 == "main" {print $4}' | grep -q online; then
    log "starting cluster $PG_VERSION/main"
    as_root pg_ctlcluster "$PG_VERSION" main start 3>&-  # the server must not hold the DSN pipe open
fi
for _ in $(seq 1 30); do
    pg_isready -q -h 127.0.0.1 -p "$(port)" && break
    sleep 0.5
done
pg_isready -q -h 127.0.0.1 -p "$(port)" || { log "server on port $(port) does not answer"; exit 1; }

# Role with a password (pg_hba's default for host 127.0.0.1 is scram-sha-256), database, extension.
as_postgres psql -p "$(port)" -XqAt -v ON_ERROR_STOP=1 <<SQL >/dev/null
SELECT 'CREATE ROLE $ROLE LOGIN' WHERE NOT EXISTS (SELECT FROM pg_roles WHERE rolname = '$ROLE')\gexec
ALTER ROLE $ROLE LOGIN PASSWORD '$PASSWORD';
SELECT 'CREATE DATABASE $DB OWNER $ROLE' WHERE NOT EXISTS (SELECT FROM pg_database WHERE datname = '$DB')\gexec
SQL
as_postgres psql -p "$(port)" -d "$DB" -XqAt -v ON_ERROR_STOP=1 \
    -c 'CREATE EXTENSION IF NOT EXISTS postgis' >/dev/null
PGCONNECT_TIMEOUT=5 psql "$(dsn)" -XtAqc 'SELECT postgis_lib_version()' >/dev/null \
    || { log "cannot log in as $ROLE over TCP: check pg_hba.conf for host 127.0.0.1/32"; exit 1; }
log "ready"
{ dsn; echo; } >&3
