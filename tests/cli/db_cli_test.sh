#!/usr/bin/env bash
# The `arscout db` commands end to end on a SQLite file: results, exit codes,
# and that rejected input leaves the store unchanged.
set -uo pipefail
arscout=${1:?usage: db_cli_test.sh ARSCOUT}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
url="sqlite:$dir/store.db"
failures=0; passed=0

check() {  # check NAME EXPECTED_EXIT COMMAND... ; output in $out
  local name=$1 want=$2; shift 2
  out=$("$@" 2>&1); local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL $name: exit $got, want $want: $out"; failures=$((failures + 1))
  else
    passed=$((passed + 1))
  fi
}
contains() {  # contains NAME TEXT
  if [[ "$out" != *"$2"* ]]; then
    echo "FAIL $1: output lacks '$2': $out"; failures=$((failures + 1))
  else
    passed=$((passed + 1))
  fi
}

check version 0 "$arscout" --version
contains version 'arscout 0.'
check init 0 "$arscout" db init "$url"
contains init '"schema_version":2'
check put 0 "$arscout" db put "$url" /captures/c1 '{"gps":{"lat":47.0,"lon":15.0}}' --kind capture --expect-version 0
contains put '"version":1'
check get 0 "$arscout" db get "$url" /captures/c1
contains get '"kind": "capture"'
check patch 0 "$arscout" db patch "$url" /captures/c1 '{"status":"registered"}' --expect-version 1
contains patch '"version":2'
check ls 0 "$arscout" db ls "$url" '/captures/*'
contains ls $'/captures/c1\tcapture\tv2'
check subtree 0 "$arscout" db get "$url" / --depth 2
contains subtree '"path":"/captures/c1"'
before=$("$arscout" db changes "$url"; "$arscout" db stats "$url")

check bad-path 2 "$arscout" db put "$url" /a/../b '{}'
contains bad-path "invalid_path"
check bad-json 2 "$arscout" db put "$url" /a '{"x":'
contains bad-json "not valid JSON"
check not-object 2 "$arscout" db put "$url" /a '[1,2]'
contains not-object "JSON object"
check conflict 3 "$arscout" db put "$url" /captures/c1 '{}' --expect-version 1
contains conflict "current is version 2"
check missing 4 "$arscout" db get "$url" /captures/none
check rm-missing 4 "$arscout" db rm "$url" /captures/none
check bad-url 2 "$arscout" db get "mysql://x" /a
check unopenable 5 "$arscout" db get "sqlite:$dir/no/such/dir.db" /a
check bad-pattern 2 "$arscout" db changes "$url" --pattern '/a*'
check no-args 2 "$arscout" db put "$url"
# The global --log-level after the command, as before it (issue 38).
check log-level-after 0 "$arscout" db stats "$url" --log-level info
check log-level-before 0 "$arscout" --log-level info db stats "$url"
check log-level-bad 2 "$arscout" db stats "$url" --log-level loud
# Nothing to revoke is "no such" (4), as the exit-code table says.
check revoke-nothing 4 "$arscout" token revoke --db "$url" --id abcdef0123
contains revoke-nothing "no token matches"
# A collector's grace shorter than the engine's state interval allows.
check gc-grace 2 "$arscout" engine --db "$url" --state-interval 200
contains gc-grace "give at least 460 seconds"
check export-no-site 4 "$arscout" export --db "$url" --site nosuchsite --format ply --output "$dir/x.ply"
contains export-no-site "no site nosuchsite"
after=$("$arscout" db changes "$url"; "$arscout" db stats "$url")
if [ "$before" != "$after" ]; then
  echo "FAIL: rejected commands changed the store"; failures=$((failures + 1))
else
  passed=$((passed + 1))
fi

check changes 0 "$arscout" db changes "$url" --since 1
contains changes '"op":"patch"'
check rm 0 "$arscout" db rm "$url" /captures/c1 --expect-version 2
check help 0 "$arscout" db tail --help
contains help "follow the change feed"

# tail prints changes committed while it runs
"$arscout" db tail "$url" --pattern '/live/*' > "$dir/tail.out" 2>&1 &
tail_pid=$!
sleep 0.5
"$arscout" db put "$url" /live/x '{}' >/dev/null
"$arscout" db put "$url" /other/y '{}' >/dev/null
for _ in $(seq 1 50); do grep -q /live/x "$dir/tail.out" && break; sleep 0.1; done
kill -TERM "$tail_pid"; wait "$tail_pid"; tail_rc=$?
out=$(cat "$dir/tail.out")
contains tail '"path":"/live/x"'
if [[ "$out" == *"/other/y"* || $tail_rc -ne 0 ]]; then
  echo "FAIL tail: pattern not applied or bad exit $tail_rc: $out"; failures=$((failures + 1))
else
  passed=$((passed + 1))
fi

echo "$passed passed, $failures failed"
[ "$failures" -eq 0 ]
