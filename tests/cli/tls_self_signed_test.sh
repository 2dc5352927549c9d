#!/usr/bin/env bash
# `arscout serve --tls-self-signed`: HTTPS with a certificate made on first
# start and kept, that a client trusting only that certificate verifies for
# 127.0.0.1; the printed fingerprint is the certificate's (openssl says so)
# and a second start reuses the same certificate.
set -uo pipefail
arscout=$(realpath "${1:?usage: tls_self_signed_test.sh ARSCOUT}")
bin=$arscout
# shellcheck source=../support/serve_script.sh
source "$(dirname "$0")/../support/serve_script.sh"
use_work_dir
dir=$work
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

start() {  # start LOG: serve on a free port, sets $server, $url and $port
  start_server "$1" --db "sqlite:$dir/store.db" --listen 127.0.0.1:0 \
    --tls-self-signed --tls-dir "$dir/tls"
  port=${url##*:}
}
stop() { kill "$server"; wait "$server" 2>/dev/null; server=""; }

start "$dir/first.log"
grep -q '^TLS: made self-signed certificate' "$dir/first.log" || fail "first start made no certificate: $(cat "$dir/first.log")"
printed=$(sed -n 's/^TLS certificate SHA-256 fingerprint //p' "$dir/first.log")
actual=$(openssl x509 -in "$dir/tls/cert.pem" -noout -fingerprint -sha256 | sed 's/^.*Fingerprint=//')
[ -n "$printed" ] && [ "$printed" = "$actual" ] || fail "printed fingerprint '$printed', certificate's '$actual'"
verify=$(echo | openssl s_client -connect "127.0.0.1:$port" -CAfile "$dir/tls/cert.pem" \
  -verify_return_error -verify_ip 127.0.0.1 2>&1)
grep -q 'Verify return code: 0 (ok)' <<< "$verify" || fail "TLS verification failed: $(grep -i verify <<< "$verify")"
health=$(printf 'GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n' |
  openssl s_client -quiet -connect "127.0.0.1:$port" -CAfile "$dir/tls/cert.pem" 2>/dev/null)
grep -q '"status":"ok"' <<< "$health" || fail "no /healthz over HTTPS: $health"
stop

start "$dir/second.log"
grep -q '^TLS: reusing self-signed certificate' "$dir/second.log" || fail "second start did not reuse: $(cat "$dir/second.log")"
again=$(sed -n 's/^TLS certificate SHA-256 fingerprint //p' "$dir/second.log")
[ "$again" = "$printed" ] || fail "second start's fingerprint '$again' differs from '$printed'"
stop

# --tls-self-signed with --tls-cert is a usage error.
"$arscout" serve --db "sqlite:$dir/store.db" --tls-self-signed --tls-cert x.pem > /dev/null 2>&1
[ $? -ne 0 ] || fail "--tls-self-signed with --tls-cert was accepted"

if [ "$failures" -ne 0 ]; then echo "$failures failure(s)"; exit 1; fi
echo "serve --tls-self-signed: verified HTTPS, fingerprint $printed, reused on restart"
