#!/usr/bin/env bash
# Simulates the LiDAR training data of the obmnet LiDAR configs with obm-sim, in cities the
# benchmarks never use (the benchmark sequences are seeds 1 and 5):
#   urban    kitti_like_urban seeds 11, 12 (500 sweeps each, training) and 21 (200, validation):
#            config/obmnet/train_lidar.yaml
#   revisits urban_revisits seeds 11, 12 (training) and 21 (validation), whole drives (~1300
#            sweeps each) that revisit their streets from both directions: the loop pairs of
#            config/obmnet/train_lidar_pairs.yaml
#   labels   the revisits, plus slam_poses.txt in each training drive: the trajectory obm-map
#            estimates on it with ICP alone (its trajectory_kitti.txt), the self-supervised pose
#            labels of config/obmnet/train_lidar_small.yaml (ground truth only scores that run)
#   scripts/make_lidar_training_data.sh [OUT_DIR=runs/lidar_data] [BUILD_DIR=build] [SET=all|urban|revisits|labels]
set -euo pipefail
out=${1:-runs/lidar_data}
build=${2:-build}
bin=$build/bin/obm-sim
set_name=${3:-all}
case "$set_name" in all|urban|revisits|labels) ;; *) echo "unknown set '$set_name' (all, urban, revisits, labels)" >&2; exit 2;; esac
mkdir -p "$out"
specs=()
[[ "$set_name" == all || "$set_name" == urban ]] && specs+=(kitti_like_urban:urban:11:500 kitti_like_urban:urban:12:500 kitti_like_urban:urban:21:200)
[[ "$set_name" == all || "$set_name" == revisits || "$set_name" == labels ]] && specs+=(urban_revisits:revisit:11:0 urban_revisits:revisit:12:0 urban_revisits:revisit:21:0)
for spec in "${specs[@]}"; do
  IFS=: read -r preset prefix seed frames <<<"$spec"
  dir="$out/${prefix}_s$seed"
  if [[ -f "$dir/poses.txt" ]]; then echo "[lidar-data] $dir exists"; continue; fi
  "$bin" -p "$preset" -s "$seed" -n "$frames" -q -o "$dir"
done
if [[ "$set_name" == labels ]]; then
  # obm-map finds poses.txt next to velodyne/ and scores its run with it (metrics.json: the
  # labels' own error); it never steers the estimate.
  for seed in 11 12; do
    dir="$out/revisit_s$seed"
    if [[ -f "$dir/slam_poses.txt" ]]; then echo "[lidar-data] $dir/slam_poses.txt exists"; continue; fi
    run="$out/labels_run_s$seed"
    "$build/bin/obm-map" -c config/map_kitti.yaml -i "$dir" -o "$run" --matcher icp --no-map -q
    cp "$run/trajectory_kitti.txt" "$dir/slam_poses.txt.tmp" && mv "$dir/slam_poses.txt.tmp" "$dir/slam_poses.txt"
  done
fi
echo "[lidar-data] sequences in $out"
