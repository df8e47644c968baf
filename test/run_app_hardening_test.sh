#!/usr/bin/env bash
# The apps' exception boundary and input checks (docs/hardening.md, classes 3 and 8): every
# failure is one line on stderr and a non-zero exit code below 128 (no signal, no
# "terminate called"), also when the result was computed and only writing it fails; and
# -no_output writes no clouds.
# Usage: run_app_hardening_test.sh PCL_MI_ALIGN DATA_DIR WORK_DIR
set -u
app=$1 data=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
source_scan=$data/kitti/sequences/02/velodyne/000006.bin
target_scan=$data/kitti/sequences/02/velodyne/000000.bin
failures=0

# expect_failure NAME PATTERN COMMAND...: non-zero exit below 128, PATTERN on stderr.
expect_failure() {
  local name=$1 pattern=$2
  shift 2
  timeout 120 "$@" >"$work/$name.out" 2>"$work/$name.err"
  local rc=$?
  if [ "$rc" -eq 0 ] || [ "$rc" -ge 124 ]; then
    echo "FAIL $name: exit code $rc"; cat "$work/$name.err"; failures=$((failures + 1)); return
  fi
  if grep -q "terminate called" "$work/$name.err" || ! grep -q "$pattern" "$work/$name.err"; then
    echo "FAIL $name: stderr lacks '$pattern'"; cat "$work/$name.err"; failures=$((failures + 1))
    return
  fi
  echo "ok   $name (exit $rc): $(grep "$pattern" "$work/$name.err" | head -n 1)"
}

# An unwritable output after a successful alignment: the result is printed, then the error.
expect_failure unwritable_output "cannot write '/nonexistent/dir/a.pcd'" \
  "$app" "$source_scan" "$target_scan" -aligned /nonexistent/dir/a.pcd -merged "$work/m.pcd"
grep -q "Final transformation" "$work/unwritable_output.out" ||
  { echo "FAIL unwritable_output: the result was not printed first"; failures=$((failures + 1)); }

# A 2 GB sparse scan under a 1.5 GB address-space cap: bad_alloc becomes a reason.
truncate -s 2G "$work/sparse.bin"
expect_failure sparse_2gb "not enough memory\|no usable points\|usable points" \
  sh -c 'ulimit -v 1500000; exec "$0" "$@"' "$app" "$work/sparse.bin" "$target_scan" \
  -aligned "$work/a.pcd" -merged "$work/m.pcd"
rm -f "$work/sparse.bin"

# A FIFO as input: refused at once instead of blocking forever.
mkfifo "$work/fifo.pcd"
expect_failure fifo_input "not a regular file" \
  "$app" "$work/fifo.pcd" "$target_scan" -aligned "$work/a.pcd" -merged "$work/m.pcd"

# A directory as output.
expect_failure directory_output "cannot write" \
  "$app" "$source_scan" "$target_scan" -aligned "$work" -merged "$work/m.pcd"

# -no_output: the result and -transform, but no clouds in the working directory.
mkdir -p "$work/no_output"
(cd "$work/no_output" && timeout 120 "$app" "$source_scan" "$target_scan" -no_output \
   -transform t.txt > out.txt 2>&1)
rc=$?
if [ "$rc" -ne 0 ] || [ -e "$work/no_output/aligned.pcd" ] || [ -e "$work/no_output/merged.pcd" ] ||
   [ ! -s "$work/no_output/t.txt" ]; then
  echo "FAIL no_output: exit $rc; files: $(ls "$work/no_output")"; failures=$((failures + 1))
else
  echo "ok   no_output (exit 0): $(ls "$work/no_output" | tr '\n' ' ')"
fi

[ "$failures" -eq 0 ] && echo "all app hardening checks passed" || exit 1
