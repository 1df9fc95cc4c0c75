#!/usr/bin/env bash
# MRPT's own command-line tools on what obmslam writes (docs/obm-map.md, "MRPT tools"), headless:
#   check_mrpt_tools.sh <bin dir> <source root> <scratch folder>
# - rawlog-edit --info reads the rawlog obm-sim writes (every sweep a CObservationPointCloud);
# - obm-map on that rawlog writes keyframes.simplemap, scene.3Dscene and trajectory_mrpt.txt;
# - observations2map builds a point map from keyframes.simplemap that lies where the drive was.
# Needs MRPT's apps (Debian package mrpt-apps): skipped (exit 77) without them, except in CI.
set -euo pipefail
bin="$1"
root="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
for t in rawlog-edit observations2map; do
  if ! command -v $t > /dev/null; then
    [[ "${CI:-}" == "true" ]] && fail "$t not installed (mrpt-apps)"
    echo "SKIP: $t not installed (mrpt-apps)"
    exit 77
  fi
done
rm -rf "$work"
mkdir -p "$work"
cd "$root"

seq="$work/seq"
"$bin/obm-sim" --preset kitti_like_urban --frames 60 --seed 7 --out "$seq" --quiet --log-level warn
[[ -s "$seq/sequence.rawlog" ]] || fail "obm-sim wrote no sequence.rawlog"
rawlog-edit --info -i "$seq/sequence.rawlog" > "$work/info.txt" 2>&1 || { cat "$work/info.txt"; fail "rawlog-edit --info"; }
grep -q 'Overall number of objects *: 60' "$work/info.txt" || { cat "$work/info.txt"; fail "rawlog-edit: expected 60 objects"; }

out="$work/out"
"$bin/obm-map" --config config/map_kitti.yaml --input "$seq/sequence.rawlog" --out "$out" --no-map \
  --matcher icp -q > "$work/map.log" 2>&1 || { tail -20 "$work/map.log"; fail "obm-map on the rawlog"; }
for f in keyframes.simplemap scene.3Dscene trajectory_mrpt.txt; do
  [[ -s "$out/$f" ]] || fail "obm-map: missing $out/$f"
done
[[ $(grep -c . "$out/trajectory_mrpt.txt") -eq 60 ]] || fail "trajectory_mrpt.txt: 60 poses expected"
[[ $(awk '{print NF}' "$out/trajectory_mrpt.txt" | sort -u) == "7" ]] || fail "trajectory_mrpt.txt: t x y z yaw pitch roll"

(cd "$out" && echo | timeout 300 observations2map "$root/config/mrpt/observations2map.ini" \
  keyframes.simplemap mrpt_map > "$work/o2m.log" 2>&1) || { cat "$work/o2m.log"; fail "observations2map"; }
grep -q 'Loading simplemap...done' "$work/o2m.log" || { cat "$work/o2m.log"; fail "observations2map did not load the simple map"; }
pts="$out/mrpt_map_mrpt__maps__CSimplePointsMap_00.txt"
[[ -s $pts ]] || { ls "$out"; fail "observations2map wrote no point map"; }
n=$(grep -c . "$pts")
(( n > 10000 )) || fail "observations2map: only $n points"
# The points surround the drive: their mean lies within 60 m of the trajectory's mean.
read -r mx my < <(awk '{x+=$1; y+=$2} END {printf "%f %f\n", x/NR, y/NR}' "$pts")
read -r tx ty < <(awk '{x+=$2; y+=$3} END {printf "%f %f\n", x/NR, y/NR}' "$out/trajectory_mrpt.txt")
lt "$(awk -v a="$mx" -v b="$my" -v c="$tx" -v d="$ty" 'BEGIN {print sqrt((a-c)^2 + (b-d)^2)}')" 60 ||
  fail "observations2map's points ($mx, $my) are far from the drive ($tx, $ty)"
# A rawlog with nothing obm-map can play (MRPT's own rot_scan_velodyne.rawlog: one
# CObservationRotatingScan, which MRPT 2.5 cannot unproject) is a clear error, not 0 frames.
rot=/usr/share/mrpt/datasets/rot_scan_velodyne.rawlog
if [[ -f $rot ]]; then
  if "$bin/obm-map" --config config/map_kitti.yaml --input "$rot" --out "$work/rot" --no-map -q \
      > "$work/rot.log" 2>&1; then
    fail "obm-map must fail on a rawlog without playable observations"
  fi
  grep -q 'no observation obm-map can play (it holds 1 CObservationRotatingScan)' "$work/rot.log" ||
    { cat "$work/rot.log"; fail "the error must name what the rawlog holds"; }
fi
echo "MRPT tools on obmslam's files: OK ($n points from observations2map)"
