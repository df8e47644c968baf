#!/usr/bin/env bash
# The binning and table code on small hand-made CSVs: test/data/compare_small.csv (the
# original 14 columns) gives means per 1 m / 2 deg bin, median runtime, success rate and the
# summary; test/data/compare_bias.csv (with the signed error and transform columns) gives the
# bias table; test/data/compare_reasons.csv (every column, with MI's refusals and their
# reasons, quoted) gives the refusals by kind and reads back as written.
# Usage: run_compare_tables_test.sh COMPARE_BINARY SMALL_CSV BIAS_CSV REASONS_CSV
set -euo pipefail
out=$("$1" -merge "$2" -methods mi-varz,gicp)
echo "$out"
expect() { echo "$out" | grep -Eq "$1" || { echo "missing line matching: $1"; exit 1; }; }
# Translation: bin 1-2 m holds mi-varz 0.1, 0.3 (mean 0.2) and gicp 1.0, 3.0 (mean 2.0).
expect '^1-2 m +0\.200 +2\.000 +2$'
expect '^3-4 m +0\.050 +0\.200 +1$'
# Rotation: bin 0-2 deg (initial 1 deg) and 4-6 deg (initial 5 deg).
expect '^0-2 deg +0\.300 +3\.000 +2$'
expect '^4-6 deg +0\.100 +0\.300 +1$'
# Median runtime of bin 1-2 m: mi-varz (0.5, 0.7) -> 0.6, gicp (2, 4) -> 3.
expect '^1-2 m +0\.600 +3\.000 +2$'
# Success (< 0.5 m, < 2 deg): gicp fails both rows of bin 1-2 m (1.0 m and 3.0 m).
expect '^1-2 m +100\.0 +0\.0 +2$'
# Summary: 3 rows each; gicp 1 of 3 succeeds; median times 0.6 and 3.0 -> ratio 5.0x.
expect '^mi-varz +3 +100\.0% +0\.150 '
expect '^gicp +3 +33\.3% +1\.400 .* 5\.0x$'
# Verdict: every row says converged; 2 of gicp's 3 miss the bound, its 1 right row said converged.
expect '^mi-varz +3 +0\.0% +3 +100\.0%$'
expect '^gicp +3 +66\.7% +1 +100\.0%$'
# Rows without the signed error columns have no bias table.
if echo "$out" | grep -q "Mean signed"; then echo "bias table from rows without it"; exit 1; fi

# Bias: the successful mi-varz rows (2 m of motion) are off by (+1, +0.5, -0.2) % forward
# and (+2, +0.5, 0) % backward; the failed forward one (1 m off) is left out. gicp: -1 %
# along, forward only.
out=$("$1" -merge "$3" -methods mi-varz,gicp)
echo "$out"
expect '^mi-varz +forward +1 +\+1\.000 +\+0\.500 +-0\.200$'
expect '^mi-varz +backward +1 +\+2\.000 +\+0\.500 +\+0\.000$'
expect '^gicp +forward +1 +-1\.000 +\+0\.000 +\+0\.000$'
if echo "$out" | grep -q '^gicp +backward'; then echo "gicp has no backward rows"; exit 1; fi
# Both formats merge into one file in the new one (NaN where the old rows lack a value).
merged=$(mktemp)
trap 'rm -f "$merged"' EXIT
"$1" -merge "$2" "$3" -csv "$merged" > /dev/null
test "$(head -1 "$merged" | awk -F, '{ print NF }')" -eq 64
# Every row lacks a value somewhere: the old rows their poses, all of them MI's confidence.
test "$(grep -c ',nan,' "$merged")" -eq 10

# Refusals: two rows refused as degenerate (one right, one 3 m off), one for weak evidence
# and one for a capped search (both right), one failure; the converged row has none. Rows
# without the column print no such table.
out=$("$1" -merge "$4" -methods mi-varz)
echo "$out"
expect '^mi-varz +degenerate +2 +1$'
expect '^mi-varz +weak evidence +1 +1$'
expect '^mi-varz +the search capped +1 +1$'
expect '^mi-varz +failed +1 +0$'
test "$(echo "$out" | grep -c '^mi-varz  *[a-z ]* [0-9]  *[0-9]$')" -eq 4
if "$1" -merge "$3" -methods mi-varz | grep -q "by kind of reason"; then echo "refusals from rows without them"; exit 1; fi
# The reasons, commas and doubled quotes in them, read back as written (before the two
# restart and the two reverse columns, NaN where the file had none), and a file written by
# -merge merges into itself.
"$1" -merge "$4" -csv "$merged" > /dev/null
without_restarts() { grep -v '^sequence,' "$1" | sed 's/\(,-\{0,1\}nan\)\{4\}$//'; }
test "$(without_restarts "$merged" | wc -l)" -eq "$(grep -c '\(,-\{0,1\}nan\)\{4\}$' "$merged")"
diff <(grep -o '"[^"]*\("".*\)*"$' "$4") <(without_restarts "$merged" | grep -o '"[^"]*\("".*\)*"$')
again=$(mktemp)
trap 'rm -f "$merged" "$again"' EXIT
"$1" -merge "$merged" -csv "$again" > /dev/null
cmp "$merged" "$again"
grep -q ',"the source is ""empty"", or holds no point",nan,nan,nan,nan$' "$merged"
# The restart and reverse columns read back as written, a restart that left the basin as
# inf.
restarts=$(mktemp)
trap 'rm -f "$merged" "$again" "$restarts"' EXIT
sed '$ s/,nan,nan,nan,nan$/,3.25,inf,0.036,0.13/' "$merged" > "$restarts"
"$1" -merge "$restarts" -csv "$again" > /dev/null
test "$(tail -1 "$again" | grep -c ',3.25,inf,0.036,0.13$')" -eq 1
