#!/usr/bin/env bash
# The main job: installs what is missing (Debian packages), builds (incrementally), then runs the
# demo on data the project makes itself — no external data needed:
#   1. simulates a short KITTI-like urban LiDAR drive around a block and back to its start (a loop;
#      preset urban_block_loop, 551 HDL-64 sweeps) with ground truth (obm-sim),
#   2. maps it with the mapping app (obm-map) when built, else integrates the ground-truth
#      trajectory, and exports the OctoMap (obm-octomap),
#   3. registers object pairs with the trained OBMNet model against the classical peers (obm-bench).
# Results and pictures go to out/demo/ (or $OBM_DEMO_OUT). Safe to re-run.
#   scripts/run.sh [--frames N]      # N = 0 (default): the whole drive
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
FRAMES=0
if [[ "${1:-}" == "--frames" ]]; then FRAMES="$2"; fi
OUT="${OBM_DEMO_OUT:-$ROOT/out/demo}"

"$ROOT/scripts/setup.sh"
"$ROOT/scripts/build.sh" "$ROOT/build"
BIN="$ROOT/build/bin"
MESHES="$("$ROOT/scripts/get_cgal_meshes.sh")"
export OBM_CGAL_DATA="$MESHES"
mkdir -p "$OUT"
t0=$(date +%s)

echo "== 1/3 simulating a drive around a block of a procedural city, HDL-64 at 10 Hz (obm-sim) =="
"$BIN/obm-sim" --preset urban_block_loop --frames "$FRAMES" --seed 5 --out "$OUT/urban" --overwrite

echo "== 2/3 mapping =="
if [[ -x "$BIN/obm-map" ]]; then
  "$BIN/obm-map" --config config/map_kitti.yaml --input "$OUT/urban" --gt "$OUT/urban/poses.txt" --out "$OUT/map"
  TRAJ="$OUT/map/trajectory_kitti.txt"
  echo "-- obm-map metrics ($OUT/map/metrics.json, timing.json):"
  python3 - "$OUT/map" <<'PY' || true
import json, sys
m = json.load(open(sys.argv[1] + "/metrics.json")); t = json.load(open(sys.argv[1] + "/timing.json"))
f = lambda v, fmt: "n/a" if v is None else fmt % v
print("   t_err %s %%   r_err %s deg/100m   ATE %s m   loops %s   matcher %s   %s frames/s" % (
    f(m.get("t_err_percent"), "%.3f"), f(m.get("r_err_deg_per_100m"), "%.3f"),
    f(m.get("ate_rmse_m"), "%.3f"), m.get("loops_accepted"), m.get("matcher"),
    f(t.get("frames_per_second"), "%.1f")))
PY
else
  TRAJ="$OUT/urban/poses.txt"
fi
if [[ -x "$BIN/obm-octomap" ]]; then
  "$BIN/obm-octomap" --input "$OUT/urban" --trajectory "$TRAJ" --resolution 0.2 --out "$OUT/urban_map.bt" \
    --png "$OUT/urban_map_top.png"
fi

echo "== 3/3 object registration: OBMNet vs classical peers (obm-bench) =="
MODEL="$ROOT/share/obmslam/models/obmnet_objects.pt"
if [[ -f "$MODEL" ]]; then
  "$BIN/obm-bench" --model "$MODEL" --protocol partial --group unseen -n 20 --threads 2 \
    --json "$OUT/bench.json" --markdown "$OUT/bench.md"
else
  echo "(no trained model at $MODEL: train one with obm-train, see docs/training.md)"
fi

echo
echo "demo done in $(( $(date +%s) - t0 )) s; results in $OUT:"
ls -1 "$OUT" | sed 's/^/  /'
find "$OUT" -maxdepth 2 -name '*.png' | sed 's/^/  picture: /'
