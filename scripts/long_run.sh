#!/usr/bin/env bash
# Long run of obm-map: memory and frame rate over a 20 000-sweep drive (the "Long run" table of
# docs/benchmarks.md).
#
#   scripts/long_run.sh [options] DATA_DIR OUT_DIR
#
# The drive is config/sim/long_laps_vlp16.yaml (made with obm-sim in DATA_DIR/long_laps_vlp16 when
# missing, ~7 GB): one city block driven 37 times round, 20 319 VLP-16 sweeps, 14.8 km. After the
# first lap the map stops growing, so obm-map's resident set should stop growing too, and the frame
# rate should not decay. While obm-map runs, its resident set (VmRSS) and the frame its progress
# bar shows are sampled every --every seconds into OUT_DIR/samples.csv; at the end
# scripts/long_run_table.py prints the table: per block of frames, frames/s and the resident set,
# and the growth in MB per km after the first lap.
#
# Options:
#   --build DIR     build folder with bin/obm-map and bin/obm-sim       [default: ROOT/build]
#   --config F      obm-map configuration                  [default: config/map_kitti.yaml]
#   --frames N      map only the first N sweeps (0 = all)                       [default: 0]
#   --every S       sampling period [s]                                        [default: 5]
#   --nice N        niceness of obm-map                                         [default: 0]
#   --no-map        no OctoMap (the front-end and the pose graph alone)
#   --set KEY=VAL   passed to obm-map (repeatable)
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$ROOT/build
CFG=$ROOT/config/map_kitti.yaml
FRAMES=0
EVERY=5
NICE=0
SETS=()
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; }
while [[ $# -gt 0 ]]; do
  case $1 in
    -h|--help) usage; exit 0 ;;
    --build) BUILD=$2; shift 2 ;;
    --config) CFG=$2; shift 2 ;;
    --frames) FRAMES=$2; shift 2 ;;
    --every) EVERY=$2; shift 2 ;;
    --nice) NICE=$2; shift 2 ;;
    --set) SETS+=(--set "$2"); shift 2 ;;
    --no-map) SETS+=(--no-map); shift ;;
    -*) echo "long_run.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) break ;;
  esac
done
[[ $# -eq 2 ]] || { echo "usage: scripts/long_run.sh [options] DATA_DIR OUT_DIR (see --help)" >&2; exit 2; }
DATA=$1
OUT=$2
for b in obm-map obm-sim; do
  [[ -x $BUILD/bin/$b ]] || { echo "long_run.sh: $BUILD/bin/$b not found: build first (scripts/build.sh)" >&2; exit 1; }
done
mkdir -p "$DATA" "$OUT"
SEQ=$DATA/long_laps_vlp16
if [[ ! -f $SEQ/sim_info.yaml ]]; then
  echo "long_run.sh: simulating $SEQ (20 319 sweeps, ~7 GB) ..." >&2
  "$BUILD/bin/obm-sim" -c "$ROOT/config/sim/long_laps_vlp16.yaml" -o "$SEQ" --overwrite -q
fi

RUN=$OUT/map
rm -rf "$RUN"
LOG=$OUT/obm-map.log
SAMPLES=$OUT/samples.csv
echo "elapsed_s,rss_mb,frame" > "$SAMPLES"
start=$(date +%s.%N)
nice -n "$NICE" "$BUILD/bin/obm-map" -c "$CFG" -i "$SEQ" -o "$RUN" -n "$FRAMES" "${SETS[@]}" 2> "$LOG" &
PID=$!
trap 'kill $PID 2>/dev/null || true' INT TERM
while kill -0 "$PID" 2>/dev/null; do
  sleep "$EVERY"
  rss=$(awk '/^VmRSS:/ {print $2 / 1024}' "/proc/$PID/status" 2>/dev/null || true)
  [[ -n $rss ]] || break
  # The progress bar's last update: "... N/M ..." (carriage-return separated).
  frame=$(tr '\r' '\n' < "$LOG" | grep -oE '[0-9]+/[0-9]+' | tail -1 | cut -d/ -f1 || true)
  now=$(date +%s.%N)
  awk -v a="$now" -v b="$start" -v r="$rss" -v f="${frame:-0}" 'BEGIN { printf "%.1f,%s,%s\n", a - b, r, f }' >> "$SAMPLES"
done
wait "$PID"
python3 "$ROOT/scripts/long_run_table.py" "$SAMPLES" "$RUN" "$SEQ" | tee "$OUT/table.md"
