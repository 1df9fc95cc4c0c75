#!/usr/bin/env bash
# Registration on realistic pairs (docs/benchmarks.md, "Realistic pairs"): every row of the pair
# kind's preset (config/presets: objects_resampled, lidar) in one obm-bench run per pair set, the
# confidence scores rated by AUROC.
#   objects  `resampled` (independent samplings, 768-point crops, σ 0.005) on the unseen group,
#            then the paper's `partial` protocol (shared samples) as a reported row
#   lidar    sweep pairs (i, i+k), k = 1, 5, 10, 20, and loop pairs of an urban_revisits drive of
#            seed 5 (a city no training run uses), recall RRE < 1° and RTE < 0.3 m
#
#   scripts/bench_realistic.sh [OUT_DIR=out/bench_realistic] [SETS="objects lidar"]
# Environment: BUILD (build), PAIRS (200), THREADS (2), OBJECT_MODEL, LIDAR_MODEL (another model
# than the preset's), METHODS (other rows than the preset's, comma-separated), LIDAR_DATA
# (out/bench_lidar: where the seed-5 drive is simulated once).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out=${1:-out/bench_realistic}
sets=${2:-objects lidar}
build=${BUILD:-build}
bin=$build/bin/obm-bench
pairs=${PAIRS:-200}
threads=${THREADS:-2}
object_model=()
[[ -n "${OBJECT_MODEL:-}" ]] && object_model=(--model "$OBJECT_MODEL")
lidar_model=()
[[ -n "${LIDAR_MODEL:-}" ]] && lidar_model=(--model "$LIDAR_MODEL")
lidar_data=${LIDAR_DATA:-out/bench_lidar}
methods=()
[[ -n "${METHODS:-}" ]] && methods=(--methods "$METHODS")
mkdir -p "$out"
for set in $sets; do
  case "$set" in
    objects)
      for protocol in resampled partial; do
        echo "[bench-realistic] objects $protocol"
        "$bin" "${object_model[@]}" "${methods[@]}" --protocol "$protocol" --group unseen -n "$pairs" --seed 1 -q \
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
        "$bin" "${lidar_model[@]}" "${methods[@]}" \
          --protocol kitti --sequence "$seq" --pair-class "$cls" -n "$pairs" --seed 1 -q \
          --threads "$threads" \
          --json "$out/lidar_$cls.json" --markdown "$out/lidar_$cls.md" \
          --per-pair "$out/lidar_$cls.csv"
      done ;;
    *) echo "unknown set '$set' (objects, lidar)" >&2; exit 2 ;;
  esac
done
cat "$out"/*.md
