#!/usr/bin/env bash
# `arscout token create --qr`: the PNG and the terminal drawing both decode
# (zbarimg, Debian's zbar-tools) to the scout app's address with the token;
# bad --qr arguments are refused before any token is made.
set -uo pipefail
arscout=$(realpath "${1:?usage: token_qr_test.sh ARSCOUT}")
if ! command -v zbarimg > /dev/null; then
  if [ "${CI:-}" = true ]; then echo "FAIL: zbarimg missing (deploy/install-deps.sh)"; exit 1; fi
  echo "SKIP: zbarimg is not installed (deploy/install-deps.sh)"; exit 77
fi
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cd "$dir" || exit 1
db="sqlite:$dir/store.db"
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

url="https://192.0.2.7:8443/scout/"
"$arscout" token create --db "$db" --role scout --name alice --qr "$url" \
  > out.txt 2> err.txt || fail "token create --qr exited $?: $(cat err.txt)"
token=$(head -1 out.txt)
[[ "$token" =~ ^ars_[0-9a-f]{64}$ ]] || fail "first line is not a token: $token"
png="scout-alice-qr.png"
[ -f "$png" ] || fail "no $png"
decoded=$(zbarimg --raw -q "$png" 2> /dev/null)
[ "$decoded" = "$url#token=$token" ] || fail "PNG decodes to '$decoded'"

# The terminal drawing: each character an upper half block whose ANSI
# foreground is the upper module and background the lower; drawn back as a
# PGM image (4 px per module) for zbarimg.
node - out.txt terminal.pgm <<'JS' || fail "cannot redraw the terminal QR code"
const fs = require('fs');
const [input, output] = process.argv.slice(2);
const rows = [];
for (const line of fs.readFileSync(input, 'utf8').split('\n')) {
  const cells = [...line.matchAll(/\x1b\[3([07]);4([07])m\u2580/g)];
  if (!cells.length) continue;
  rows.push(cells.map((m) => m[1] === '0'));
  rows.push(cells.map((m) => m[2] === '0'));
}
if (!rows.length) throw new Error('no QR drawing in the output');
const scale = 4, w = rows[0].length * scale, h = rows.length * scale;
const pixels = Buffer.alloc(w * h);
for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
  pixels[y * w + x] = rows[Math.floor(y / scale)][Math.floor(x / scale)] ? 0 : 255;
}
fs.writeFileSync(output, Buffer.concat([Buffer.from(`P5\n${w} ${h}\n255\n`), pixels]));
JS
decoded=$(zbarimg --raw -q terminal.pgm 2> /dev/null)
[ "$decoded" = "$url#token=$token" ] || fail "terminal drawing decodes to '$decoded'"

# --qr-png names the file.
"$arscout" token create --db "$db" --role scout --name bob --qr "$url" \
  --qr-png "$dir/bob.png" > /dev/null 2>&1 || fail "--qr-png exited $?"
[ -f "$dir/bob.png" ] || fail "--qr-png wrote no file"

# Refused before a token is made: not a scout, not an http(s) address, a '#'.
before=$("$arscout" db ls "$db" '/auth/tokens/*' 2> /dev/null | wc -l)
[ "$before" -eq 2 ] || fail "db ls lists $before tokens, want alice's and bob's"
for bad in "--role planner --name p --qr $url" "--role scout --name c --qr ftp://x/" \
           "--role scout --name d --qr https://x/scout/#a"; do
  # shellcheck disable=SC2086
  "$arscout" token create --db "$db" $bad > /dev/null 2>&1
  rc=$?
  [ "$rc" -eq 2 ] || fail "token create $bad exited $rc, want 2"
done
after=$("$arscout" db ls "$db" '/auth/tokens/*' 2> /dev/null | wc -l)
[ "$before" = "$after" ] || fail "refused --qr calls made tokens ($before -> $after)"

if [ "$failures" -ne 0 ]; then echo "$failures failure(s)"; exit 1; fi
echo "token create --qr: PNG and terminal codes decode to the address with the token"
