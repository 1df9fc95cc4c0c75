#!/usr/bin/env bash
# The object-level registration benchmark of docs/benchmarks.md: obm-bench on the unseen test group
# (objects never used in training or model selection), 200 seeded pairs per protocol, every method
# available in one run per protocol.
#   scripts/bench_objects.sh [OUT_DIR=out/bench_objects] [MODEL=share/obmslam/models/obmnet_objects.pt]
#   BUILD=build METHODS=obmnet,obmnet+icp PAIRS=200 scripts/bench_objects.sh OUT MODEL   # a subset
set -euo pipefail
out=${1:-out/bench_objects}
model=${2:-share/obmslam/models/obmnet_objects.pt}
bin=${BUILD:-build}/bin/obm-bench
pairs=${PAIRS:-200}
mkdir -p "$out"
for protocol in clean jitter outliers partial partial_noise; do
  args=(--model "$model" --protocol "$protocol" --group unseen -n "$pairs" --seed 1 -q
        --json "$out/$protocol.json" --markdown "$out/$protocol.md")
  [[ -n "${METHODS:-}" ]] && args+=(--methods "$METHODS")
  echo "[bench-objects] $protocol"
  "$bin" "${args[@]}" --threads "${THREADS:-2}"
done
cat "$out"/{clean,jitter,outliers,partial,partial_noise}.md
