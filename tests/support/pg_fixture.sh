#!/usr/bin/env bash
# Starts or stops a throwaway PostgreSQL 15 server for tests and benchmarks.
#
#   pg_fixture.sh start STATE_DIR   initdb in a temp dir, start on 127.0.0.1 at
#                                   a free port, write the admin URL to
#                                   STATE_DIR/url
#   pg_fixture.sh stop STATE_DIR    stop the server and delete its data
#   pg_fixture.sh down STATE_DIR    stop the server (fast), keeping its data
#   pg_fixture.sh up STATE_DIR      start it again, on the same port
#   pg_fixture.sh restart STATE_DIR `pg_ctl restart` (the fault tests)
#
# As root the server runs as user 'postgres' (runuser). When PostgreSQL is not
# installed the start writes no URL and exits 0, so tests skip with a message,
# except under CI=true, where that is a failure.
set -euo pipefail

usage="usage: pg_fixture.sh start|stop|down|up|restart STATE_DIR"
cmd=${1:?$usage}
state=${2:?$usage}
bindir=${ARSCOUT_PG_BINDIR:-/usr/lib/postgresql/15/bin}

as_server_user() {
  if [ "$(id -u)" -eq 0 ]; then
    runuser -u postgres -- "$@"
  else
    "$@"
  fi
}

stop_server() {
  if [ -f "$state/datadir" ]; then
    local data
    data=$(cat "$state/datadir")
    if [ -d "$data" ]; then
      as_server_user "$bindir/pg_ctl" -D "$data" -m immediate -w stop >/dev/null 2>&1 || true
      rm -rf "$(dirname "$data")"
    fi
  fi
  rm -rf "$state"
}

free_port() {
  local port
  for _ in $(seq 1 50); do
    port=$(( (RANDOM % 20000) + 30000 ))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
      echo "$port"
      return 0
    fi
  done
  echo "no free port found" >&2
  return 1
}

start_server() {
  stop_server
  mkdir -p "$state"
  if [ ! -x "$bindir/initdb" ]; then
    if [ "${CI:-}" = "true" ]; then
      echo "PostgreSQL 15 is not installed ($bindir/initdb missing); run deploy/install-deps.sh" >&2
      exit 1
    fi
    echo "PostgreSQL 15 not installed: PostgreSQL tests will be skipped" >&2
    exit 0
  fi
  local root data port
  root=$(mktemp -d /tmp/arscout-pg.XXXXXX)
  data="$root/data"
  chmod 755 "$root"
  if [ "$(id -u)" -eq 0 ]; then chown postgres:postgres "$root"; fi
  echo "$data" > "$state/datadir"
  as_server_user "$bindir/initdb" -D "$data" -U postgres --auth=trust \
    -E UTF8 --locale=C >"$root/initdb.log" 2>&1 || {
      cat "$root/initdb.log" >&2; exit 1; }
  for attempt in 1 2 3 4 5; do
    port=$(free_port)
    echo "-p $port -k $root -c listen_addresses=127.0.0.1 -c max_connections=200" \
      > "$state/options"
    if as_server_user "$bindir/pg_ctl" -D "$data" -l "$root/server.log" -w -t 60 \
         -o "$(cat "$state/options")" start >/dev/null 2>&1; then
      echo "postgresql://postgres@127.0.0.1:$port/postgres" > "$state/url"
      echo "PostgreSQL test server on 127.0.0.1:$port (data in $data)"
      return 0
    fi
    echo "start on port $port failed (attempt $attempt):" >&2
    tail -5 "$root/server.log" >&2 || true
  done
  exit 1
}

# down/up/restart act on a server that start left running.
pg_ctl_on_data() {
  local data
  data=$(cat "$state/datadir")
  as_server_user "$bindir/pg_ctl" -D "$data" -l "$(dirname "$data")/server.log" \
    -w -t 60 "$@" >/dev/null
}

case "$cmd" in
  start) start_server ;;
  stop) stop_server ;;
  down) pg_ctl_on_data -m fast stop ;;
  up) pg_ctl_on_data -o "$(cat "$state/options")" start ;;
  restart) pg_ctl_on_data -m fast -o "$(cat "$state/options")" restart ;;
  *) echo "unknown command $cmd" >&2; exit 2 ;;
esac
