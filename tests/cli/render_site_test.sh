#!/usr/bin/env bash
# `arscout render-site` end to end, small images to stay fast: the block
# scene's files (photos, K.txt, both GPS files, Strecha cameras), the
# simulated receiver's noise level, determinism in --seed, and the street
# scene's files.
set -uo pipefail
arscout=${1:?usage: render_site_test.sh ARSCOUT}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
failures=0; passed=0

expect() {  # expect NAME CONDITION_EXIT_STATUS MESSAGE
  if [ "$2" -ne 0 ]; then
    echo "FAIL $1: $3"; failures=$((failures + 1))
  else
    passed=$((passed + 1))
  fi
}
count() { find "$1" -maxdepth 1 -name "$2" | wc -l; }

block() {  # block OUT SEED
  "$arscout" render-site --scene block --views 60 --width 128 --height 96 \
    --seed "$2" --out "$1" > "$1.log" 2>&1
}

block "$dir/a" 3; expect block-exit $? "$(tail -3 "$dir/a.log")"
[ "$(grep -c '^rendered ' "$dir/a.log")" -eq 60 ]
expect progress $? "want 60 progress lines"
[ "$(count "$dir/a/images" '*.jpg')" -eq 60 ]; expect photos $? "want 60"
[ -f "$dir/a/images/K.txt" ]; expect k-txt $? "no images/K.txt"
[ "$(count "$dir/a/gt_dense_cameras" '*.jpg.camera')" -eq 60 ]
expect cameras $? "want 60 gt_dense_cameras/*.jpg.camera"
header='image,latitude,longitude,altitude,horizontal_accuracy_m,vertical_accuracy_m'
for f in gps.csv gps_truth.csv; do
  [ "$(head -1 "$dir/a/$f")" = "$header" ]; expect "$f-header" $? "bad header"
  [ "$(wc -l < "$dir/a/$f")" -eq 61 ]; expect "$f-rows" $? "want 60 rows"
done
[ "$(sed -n 2p "$dir/a/gps.csv" | cut -d, -f5,6)" = "1.50,3.00" ]
expect accuracies $? "want 1.50,3.00"
[ "$(sed -n 2p "$dir/a/gt_dense_cameras/0000.jpg.camera" | wc -w)" -eq 3 ]
expect camera-rows $? "a K row has 3 numbers"

# The noise, in metres (a sphere is close enough over a few metres): the
# RMS per horizontal axis near 1.5 m and vertically near 3 m. With 60
# samples an RMS lands within 30 % of its sigma with odds of over 99 %.
paste -d, "$dir/a/gps.csv" "$dir/a/gps_truth.csv" | tail -n +2 | awk -F, '
  { r = 6371000; k = 3.14159265358979 / 180
    n += 1; e2 += ((($3 - $9) * k * r * cos($2 * k)) ^ 2)
    n2 += ((($2 - $8) * k * r) ^ 2); u2 += (($4 - $10) ^ 2) }
  END { e = sqrt(e2 / n); no = sqrt(n2 / n); u = sqrt(u2 / n)
        printf "east %.2f north %.2f up %.2f m RMS\n", e, no, u
        exit !(e > 1.05 && e < 1.95 && no > 1.05 && no < 1.95 &&
               u > 2.1 && u < 3.9) }' > "$dir/noise.txt"
expect noise $? "$(cat "$dir/noise.txt")"

# Deterministic in the seed, noise included; another seed, another walk.
block "$dir/b" 3
diff -r "$dir/a" "$dir/b" > /dev/null; expect same-seed $? "runs differ"
block "$dir/c" 4
! cmp -s "$dir/a/gps_truth.csv" "$dir/c/gps_truth.csv"
expect other-seed $? "seed 4 walks as seed 3"

"$arscout" render-site --views 3 --width 160 --height 120 --out "$dir/s" \
  > "$dir/s.log" 2>&1
expect street-exit $? "$(tail -3 "$dir/s.log")"
[ "$(count "$dir/s/images" '*.jpg')" -eq 3 ] && [ -f "$dir/s/gps.csv" ] &&
  [ ! -e "$dir/s/gps_truth.csv" ]
expect street-files $? "want 3 photos, gps.csv and no gps_truth.csv"

"$arscout" render-site --scene block --views 1001 --out "$dir/x" > /dev/null 2>&1
[ $? -ne 0 ]; expect too-many-views $? "--views 1001 accepted"

echo "render_site: $passed passed, $failures failed"
[ "$failures" -eq 0 ]
