#!/usr/bin/env bash
# The whole chain as a user runs it, on short simulated sequences: obm-sim makes a LiDAR drive and
# an RGB-D walk, obm-map maps each with the network (OBMNet + ICP, the shipped models), obm-octomap
# integrates the drive along obm-map's trajectory, obm-graph optimises obm-map's pose graph.
# Written for the sanitizer build (scripts/test.sh --sanitize runs it there: the apps, the
# front-end with OBMNet and LibTorch together under ASan + UBSan), and runs in any build:
#   check_end_to_end.sh <bin dir> <source root> <scratch folder>
# The ATE bounds are about 3× what the runs measure (LiDAR 0.0035 m, RGB-D 0.0022 m, the same in
# the Release and the sanitizer builds): a change that makes the mapping measurably worse fails.
set -euo pipefail
bin="$1"
root="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
rm -rf "$work"
mkdir -p "$work"
cd "$root"
run() {  # run NAME CMD...: the command's output in $work/NAME.log, shown on failure
  local name="$1"
  shift
  "$@" > "$work/$name.log" 2>&1 || { tail -30 "$work/$name.log"; fail "$name: exit $?"; }
}

# LiDAR: 40 sweeps of a KITTI-like street.
run sim_lidar "$bin/obm-sim" --preset kitti_like_urban --frames 40 --seed 7 --out "$work/drive" --quiet --log-level warn
run map_lidar "$bin/obm-map" --config config/map_kitti.yaml --input "$work/drive" --out "$work/drive_map" \
  --matcher obmnet+icp -q
for f in trajectory_kitti.txt trajectory_tum.txt graph.g2o metrics.json frames.csv map.bt; do
  [[ -s "$work/drive_map/$f" ]] || fail "obm-map (LiDAR): missing $f"
done
[[ $(wc -l < "$work/drive_map/trajectory_kitti.txt") -eq 40 ]] || fail "obm-map (LiDAR): not 40 poses"
ate=$(num ate_rmse_m "$work/drive_map/metrics.json")
lt "$ate" 0.01 || fail "obm-map (LiDAR): ATE $ate m on 40 sweeps (measured 0.0035 m)"

run octomap "$bin/obm-octomap" --input "$work/drive" --trajectory "$work/drive_map" --out "$work/drive.bt" -q
[[ -s "$work/drive.bt" ]] || fail "obm-octomap: no map"

run graph "$bin/obm-graph" --input "$work/drive_map/graph.g2o" --output "$work/graph_opt.g2o" \
  --robust dcs:auto --report "$work/graph.json" -q
[[ -s "$work/graph_opt.g2o" ]] || fail "obm-graph: no graph"
num final_chi2 "$work/graph.json" > /dev/null

# RGB-D: 30 frames of an office walk, mapped with the indoor configuration.
run sim_rgbd "$bin/obm-sim" --preset indoor_loop --frames 30 --seed 7 --out "$work/walk" --quiet --log-level warn
run map_rgbd "$bin/obm-map" --config config/map_indoor.yaml --input "$work/walk" --out "$work/walk_map" -q
[[ $(wc -l < "$work/walk_map/trajectory_tum.txt") -ge 30 ]] || fail "obm-map (RGB-D): not 30 poses"
ate=$(num ate_rmse_m "$work/walk_map/metrics.json")
lt "$ate" 0.006 || fail "obm-map (RGB-D): ATE $ate m on 30 frames (measured 0.0022 m)"
echo "end to end: LiDAR ATE $(num ate_rmse_m "$work/drive_map/metrics.json") m, RGB-D ATE $ate m"
