#!/usr/bin/env bash
# Simulates the RGB-D training data of config/obmnet/train_indoor.yaml with obm-sim: two training
# walks and one validation walk through procedural office floors that the benchmarks never use
# (indoor_loop with seeds 11, 12, 21; the indoor benchmarks drive the TUM trajectories through
# other scenes). The test group of that config is real data: Open3D's RGB-D frames in
# $OBM_SHARED_DATA/rgbd_open3d.
#   scripts/make_indoor_training_data.sh [OUT_DIR=runs/indoor_data] [BUILD_DIR=build]
set -euo pipefail
out=${1:-runs/indoor_data}
bin=${2:-build}/bin/obm-sim
mkdir -p "$out"
for spec in 11:900 12:900 21:300; do
  seed=${spec%%:*}; frames=${spec##*:}
  dir="$out/floor_s$seed"
  if [[ -f "$dir/groundtruth.txt" ]]; then echo "[indoor-data] $dir exists"; continue; fi
  "$bin" -p indoor_loop -s "$seed" -n "$frames" -q --threads 1 -o "$dir"
done
echo "[indoor-data] sequences in $out"
