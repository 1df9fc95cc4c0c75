#!/usr/bin/env bash
# Registration on realistic pairs (docs/benchmarks.md, "Realistic pairs"): every method in one
# obm-bench run per pair set, the network alone, with ICP, ICP alone and the Open3D peers, and the
# confidence scores rated by AUROC.
#   objects  `resampled` (independent samplings, 768-point crops, σ 0.005) on the unseen group,
#            then the paper's `partial` protocol (shared samples) as a reported row
#   lidar    sweep pairs (i, i+k), k = 1, 5, 10, 20, and loop pairs of an urban_revisits drive of
#            seed 5 (a city no training run uses), recall RRE < 1° and RTE < 0.3 m
#
#   scripts/bench_realistic.sh [OUT_DIR=out/bench_realistic] [SETS="objects lidar"]
# Environment: BUILD (build), PAIRS (200), THREADS (2), OBJECT_MODEL, LIDAR_MODEL, LIDAR_DATA
# (runs/bench_lidar: where the seed-5 drive is simulated once).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out=${1:-out/bench_realistic}
sets=${2:-objects lidar}
build=${BUILD:-build}
bin=$build/bin/obm-bench
pairs=${PAIRS:-200}
threads=${THREADS:-2}
object_model=${OBJECT_MODEL:-$root/share/obmslam/models/obmnet_objects_resampled.pt}
lidar_model=${LIDAR_MODEL:-$root/share/obmslam/models/obmnet_lidar_pairs.pt}
lidar_data=${LIDAR_DATA:-runs/bench_lidar}
mkdir -p "$out"
for set in $sets; do
  case "$set" in
    objects)
      for protocol in resampled partial; do
        echo "[bench-realistic] objects $protocol"
        "$bin" --model "$object_model" --protocol "$protocol" --group unseen -n "$pairs" --seed 1 -q \
          --threads "$threads" --json "$out/objects_$protocol.json" \
          --markdown "$out/objects_$protocol.md" --per-pair "$out/objects_$protocol.csv"
      done ;;
    lidar)
      seq="$lidar_data/revisit_s5"
      if [[ ! -f "$seq/poses.txt" ]]; then
        echo "[bench-realistic] simulating $seq (urban_revisits, seed 5)"
        "$build/bin/obm-sim" -p urban_revisits -s 5 -q -o "$seq"
      fi
      for cls in k1 k5 k10 k20 loop; do
        echo "[bench-realistic] lidar $cls"
        # the lidar preset (config/presets/lidar.yaml): data train_lidar_pairs.yaml, recall 1° / 0.3 m
        "$bin" --model "$lidar_model" \
          --protocol kitti --sequence "$seq" --pair-class "$cls" -n "$pairs" --seed 1 -q \
          --threads "$threads" \
          --methods "obmnet,obmnet+icp,icp,o3d_icp,o3d_fgr,o3d_ransac,o3d_fgr+icp" \
          --json "$out/lidar_$cls.json" --markdown "$out/lidar_$cls.md" \
          --per-pair "$out/lidar_$cls.csv"
      done ;;
    *) echo "unknown set '$set' (objects, lidar)" >&2; exit 2 ;;
  esac
done
cat "$out"/*.md
