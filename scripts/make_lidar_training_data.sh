#!/usr/bin/env bash
# Simulates the LiDAR training data of config/obmnet/train_lidar.yaml with obm-sim: two training
# drives and one validation drive through procedural cities that the benchmarks never use
# (kitti_like_urban with seeds 11, 12, 21; the benchmark sequence is seed 1).
#   scripts/make_lidar_training_data.sh [OUT_DIR=runs/lidar_data] [BUILD_DIR=build]
set -euo pipefail
out=${1:-runs/lidar_data}
bin=${2:-build}/bin/obm-sim
mkdir -p "$out"
for spec in 11:500 12:500 21:200; do
  seed=${spec%%:*}; frames=${spec##*:}
  dir="$out/urban_s$seed"
  if [[ -f "$dir/poses.txt" ]]; then echo "[lidar-data] $dir exists"; continue; fi
  "$bin" -p kitti_like_urban -s "$seed" -n "$frames" -q -o "$dir"
done
echo "[lidar-data] sequences in $out"
