#!/usr/bin/env bash
# Best effort: start a throw-away PostgreSQL server for the history backend tests and print the
# URL to use (nothing when it cannot: those tests then skip, saying why). Never fails CI.
set -u
PGBIN=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | tail -n 1)
if [ -z "$PGBIN" ] && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  { timeout 120 apt-get update -qq && DEBIAN_FRONTEND=noninteractive timeout 300 apt-get install -y -qq postgresql; } \
    >/dev/null 2>&1
  PGBIN=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | tail -n 1)
fi
[ -n "$PGBIN" ] || exit 0
DIR=$(mktemp -d /tmp/umbmark-pg.XXXXXX)
PORT=54329
AS=""
if [ "$(id -u)" = 0 ]; then
  id postgres >/dev/null 2>&1 || exit 0
  chown postgres "$DIR"
  AS="runuser -u postgres --"
fi
$AS "$PGBIN/initdb" -D "$DIR/data" -A trust -U umbmark >/dev/null 2>&1 || exit 0
$AS "$PGBIN/pg_ctl" -D "$DIR/data" -o "-k $DIR -p $PORT -c listen_addresses=''" -w -t 60 start >/dev/null 2>&1 || exit 0
$AS "$PGBIN/createdb" -h "$DIR" -p $PORT -U umbmark umbmark_test >/dev/null 2>&1 || exit 0
printf '%s "%s/pg_ctl" -D "%s/data" -m fast stop >/dev/null 2>&1; rm -rf "%s"\n' "$AS" "$PGBIN" "$DIR" "$DIR" > "$DIR/stop.sh"
echo "postgresql+psycopg://umbmark@/umbmark_test?host=$DIR&port=$PORT"
