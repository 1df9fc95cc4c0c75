#!/usr/bin/env bash
# Simulates the RGB-D training data of config/obmnet/train_indoor.yaml with obm-sim: two training
# walks and one validation walk through procedural office floors that the benchmarks never use
# (indoor_loop with seeds 11, 12, 21; the indoor benchmarks drive the TUM trajectories through
# other scenes). The test group of that config is real data: Open3D's RGB-D frames in
# $OBM_SHARED_DATA/rgbd_open3d.
# With LABELS=labels, each training walk also gets slam_groundtruth.txt: the trajectory obm-map
# estimates on it with ICP alone (its trajectory_tum.txt), the self-supervised pose labels of
# config/obmnet/train_indoor_frames_prior.yaml (the simulator's poses only score that run).
#   scripts/make_indoor_training_data.sh [OUT_DIR=runs/indoor_data] [BUILD_DIR=build] [LABELS=labels]
set -euo pipefail
out=${1:-runs/indoor_data}
build=${2:-build}
bin=$build/bin/obm-sim
labels=${3:-}
[[ -z "$labels" || "$labels" == labels ]] || { echo "unknown third argument '$labels' (labels)" >&2; exit 2; }
mkdir -p "$out"
for spec in 11:900 12:900 21:300; do
  seed=${spec%%:*}; frames=${spec##*:}
  dir="$out/floor_s$seed"
  if [[ -f "$dir/groundtruth.txt" ]]; then echo "[indoor-data] $dir exists"; continue; fi
  "$bin" -p indoor_loop -s "$seed" -n "$frames" -q --threads 1 -o "$dir"
done
if [[ "$labels" == labels ]]; then
  # obm-map scores its run with the walk's groundtruth.txt (metrics.json: the labels' own error);
  # the ground truth never steers the estimate.
  for seed in 11 12; do
    dir="$out/floor_s$seed"
    if [[ -f "$dir/slam_groundtruth.txt" ]]; then echo "[indoor-data] $dir/slam_groundtruth.txt exists"; continue; fi
    run="$out/labels_run_s$seed"
    "$build/bin/obm-map" -c config/map_indoor.yaml -i "$dir" -o "$run" --matcher icp --no-map -q
    cp "$run/trajectory_tum.txt" "$dir/slam_groundtruth.txt.tmp" && mv "$dir/slam_groundtruth.txt.tmp" "$dir/slam_groundtruth.txt"
  done
fi
echo "[indoor-data] sequences in $out"
