#!/usr/bin/env bash
# End-to-end check of the obm-sim command line as users (and the acceptance checks) call it:
#   check_obm_sim_cli.sh <obm-sim binary> <scratch folder>
set -euo pipefail
sim="$1"
work="$2"
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }

"$sim" --help >/dev/null || fail "--help"

# LiDAR preset -> KITTI layout + rawlog.
out="$work/kitti"
"$sim" --preset kitti_like_urban --frames 3 --seed 5 --out "$out" --quiet --log-level warn
for f in velodyne/000000.bin velodyne/000001.bin velodyne/000002.bin poses.txt times.txt \
         calib.txt groundtruth.txt sequence.rawlog preview_topview.png preview_frame.png; do
  [[ -s "$out/$f" ]] || fail "kitti layout: missing $f"
done
[[ ! -e "$out/velodyne/000003.bin" ]] || fail "kitti layout: too many scans"
[[ $(grep -c . "$out/poses.txt") -eq 3 ]] || fail "poses.txt must have 3 lines"
[[ $(awk '{print NF}' "$out/poses.txt" | sort -u) == "12" ]] || fail "poses.txt must have 12 numbers per line"
grep -q '^Tr:' "$out/calib.txt" || fail "calib.txt has no Tr"
size=$(stat -c %s "$out/velodyne/000000.bin")
(( size % 16 == 0 && size > 16 * 50000 )) || fail "velodyne/000000.bin: $size bytes"

# RGB-D preset -> TUM layout (needs the real TUM ground truth).
out="$work/tum"
if "$sim" --preset indoor_tum_fr1_xyz --frames 3 --seed 5 --out "$out" --quiet --log-level warn \
     2>"$work/tum.err"; then
  for f in depth.txt rgb.txt groundtruth.txt sequence.rawlog camera_intrinsic.json; do
    [[ -s "$out/$f" ]] || fail "tum layout: missing $f"
  done
  [[ $(ls "$out/depth" | wc -l) -eq 3 ]] || fail "tum layout: expected 3 depth PNGs"
else
  grep -q "OBM_SHARED_DATA" "$work/tum.err" || fail "missing TUM data must be reported clearly"
  [[ ! -e "$out" ]] || fail "a failed run left $out behind"
fi

# Bad input: clear errors, exit code 1, nothing written.
if "$sim" --preset no_such_preset --out "$work/bad" 2>"$work/bad.err"; then fail "unknown preset accepted"; fi
grep -q "no_such_preset" "$work/bad.err" || fail "unknown preset not named"
[[ ! -e "$work/bad" ]] || fail "unknown preset left output"
printf 'not a pose\n' > "$work/poses.txt"
if "$sim" --preset kitti_like_urban --trajectory "$work/poses.txt" --out "$work/bad" 2>"$work/bad.err"; then
  fail "malformed pose file accepted"
fi
grep -q "poses.txt" "$work/bad.err" || fail "malformed pose file not named"
[[ -z "$(ls -d "$work"/bad* 2>/dev/null | grep -v '\.err$' || true)" ]] || fail "bad run left output"
echo "obm-sim command line: OK"
