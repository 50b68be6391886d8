#!/usr/bin/env bash
# Start a throw-away PostgreSQL server on 127.0.0.1:$PGPORT (Debian's packages, run as postgres).
# Prints the URL to use as SCREWSNAKE_TEST_POSTGRES; `.ci/postgres.sh stop DIR` stops it.
set -euo pipefail
PGPORT=${PGPORT:-54329}
PGBIN=$(ls -d /usr/lib/postgresql/*/bin | sort -V | tail -n 1)
if [ "${1:-}" = stop ]; then
  su postgres -c "$PGBIN/pg_ctl -D $2 stop -m fast" >/dev/null 2>&1 || true
  rm -rf "$2"
  exit 0
fi
PGDATA=$(mktemp -d /tmp/screwsnake-pg.XXXXXX)
chown postgres "$PGDATA"
su postgres -c "$PGBIN/initdb -D $PGDATA -A trust -U postgres" >/dev/null
su postgres -c "$PGBIN/pg_ctl -D $PGDATA -w -l $PGDATA/server.log -o '-p $PGPORT -k /tmp -c listen_addresses=127.0.0.1' start" >/dev/null
echo "$PGDATA postgresql://postgres@127.0.0.1:$PGPORT/postgres"
