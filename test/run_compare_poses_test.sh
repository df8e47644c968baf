#!/usr/bin/env bash
# scripts/compare_poses.py, the refactoring check: a CSV against itself passes, a copy with
# one confidence and one time changed passes on the poses alone and with --every-column fails
# on the confidence only (the time is never compared), and a copy with a pose changed fails.
# Usage: run_compare_poses_test.sh SCRIPT CSV WORK_DIR
set -euo pipefail
script=$1 csv=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
/usr/bin/python3 - "$csv" "$work" <<'PY'
import csv
import sys

src, work = sys.argv[1], sys.argv[2]
with open(src, newline="") as f:
    rows = list(csv.DictReader(f))
fields = list(rows[0])


def write(name, change):
    copy = [dict(r) for r in rows]
    change(copy[1])
    with open(f"{work}/{name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(copy)


write("confidence", lambda r: r.update(confidence="0.123", seconds="9.9"))
write("pose", lambda r: r.update(estimate_03=str(float(r["estimate_03"]) + 1e-6)))
PY
"$script" "$csv" "$csv" | grep -q ', 0 differ$'
"$script" "$csv" "$work/confidence.csv" | grep -q ', 0 differ$'
if "$script" --every-column "$csv" "$work/confidence.csv" > "$work/out.txt"; then
  echo "a changed confidence passed --every-column" >&2
  exit 1
fi
grep -q ', 1 differ$' "$work/out.txt"
grep -q 'differs: .* confidence$' "$work/out.txt"
if "$script" "$csv" "$work/pose.csv" > "$work/out.txt"; then
  echo "a changed pose passed" >&2
  exit 1
fi
grep -q 'estimate_03' "$work/out.txt"
echo "compare_poses: ok"
