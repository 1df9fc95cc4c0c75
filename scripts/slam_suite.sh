#!/usr/bin/env bash
# Robustness suite of obm-map: LiDAR sequences where ICP alone is known to struggle, each mapped
# by the ICP-only pipeline and by the OBMNet pipeline in the same run (the "Robustness suite" table
# of docs/benchmarks.md). Called by `scripts/bench_slam.sh --only suite`, or directly:
#
#   scripts/slam_suite.sh [options] DATA_DIR OUT_DIR
#
# Sequences (made with obm-sim in DATA_DIR when missing; fixed seeds):
#   corridor     config/sim/suite_corridor.yaml: starts at 12 m/s in a straight street of identical,
#                gap-free facades (an ICP local minimum every ~2 m along it)
#   open_road    config/sim/suite_open_road.yaml: starts at 15 m/s on an open road, no buildings
#   urban        kitti_like_urban (seed S), gap-free: the reference the handling must not change
#   turn_gaps    kitti_like_urban (seed S) with 1, 2 and 3 s of sweeps lost inside three turns
#                (the time stamps show the gaps; scripts/drop_sweeps.py)
#   turn_jumps   the same places with 1 s lost and the time stamps rewritten (a sudden jump)
#   long_gaps    the same places with 4, 5 and 6 s lost (the time stamps show the gaps): the car
#                leaves the turn, and up to 60 m of street, unseen
#   revisits     urban_revisits (seed S): streets driven again in the opposite direction, from the
#                other lane 4 m across, and crossed at 90°
#   revisit_gaps the revisits drive with 4, 5 and 6 s lost in its three sharpest turns (the time
#                stamps show the gaps): the drive is lost and must be found again on the revisits
#   offset_revisits  config/sim/suite_offset_revisits.yaml: the same route on 22 m wide avenues,
#                driven 4.5 m right of the centre line: the opposite passes 9 m across
# Indoors (RGB-D, mapped with --indoor-config; the walks end in the room they start from):
#   indoor_walk  indoor_loop (seed S): the reference walk through an office floor, 0.6 m/s
#   indoor_fast  config/sim/suite_indoor_fast.yaml: the walk at 1.5 m/s looking around 45 deg to
#                either side (fast rotation; views of consecutive frames share less)
#   indoor_plain config/sim/suite_indoor_plain.yaml: the walk through empty rooms (bare walls:
#                degenerate views for a depth-only ICP)
# Each sequence is run with `--matcher icp` and with the configuration's matcher (obmnet+icp), and
# once more per `--model` (the configuration's matcher with that network).
# Columns: t_err / r_err (KITTI devkit), ATE RMSE, frames recovered / bridged, local-map restarts,
# loops accepted, "silent" frames (reported tracked, but their motion since the previous frame is
# off by more than 0.2 m or 1° from the ground truth's), frames/s (wall clock).
#
# Options:
#   --build DIR     build folder with bin/obm-map and bin/obm-sim       [default: ROOT/build]
#   --config F      obm-map configuration                  [default: config/map_kitti.yaml]
#   --indoor-config F  obm-map configuration of the indoor sequences [default: config/map_indoor.yaml]
#   --only LIST     comma-separated subset of the sequences above      [default: all]
#   --seed S        obm-sim seed of turn_gaps / turn_jumps / revisits     [default: 5]
#   --nice N        niceness of every run                               [default: 5]
#   --resume        keep runs that already have their results in OUT_DIR
#   --set KEY=VAL   passed to every obm-map run (repeatable)
#   --model NAME=PT another network for the OBMNet pipeline, run as pipeline obmnet_NAME
#                   (repeatable), e.g. --model small=share/obmslam/models/obmnet_lidar_small.pt
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$ROOT/build
CFG=$ROOT/config/map_kitti.yaml
ONLY=corridor,open_road,urban,turn_gaps,turn_jumps,long_gaps,revisits,revisit_gaps,offset_revisits,indoor_walk,indoor_fast,indoor_plain
ICFG=$ROOT/config/map_indoor.yaml
SEED=5
NICE=5
RESUME=0
SETS=()
MODELS=()

usage() { sed -n '2,47p' "$0" | sed 's/^# \{0,1\}//'; }
POS=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --build) BUILD=$(cd "$2" && pwd); shift 2 ;;
    --config) CFG=$(cd "$(dirname "$2")" && pwd)/$(basename "$2"); shift 2 ;;
    --indoor-config) ICFG=$(cd "$(dirname "$2")" && pwd)/$(basename "$2"); shift 2 ;;
    --only) ONLY=$2; shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --nice) NICE=$2; shift 2 ;;
    --resume) RESUME=1; shift ;;
    --set) SETS+=(--set "$2"); shift 2 ;;
    --model)
      [[ $2 == *=* ]] || { echo "slam_suite.sh: --model wants NAME=PATH, got '$2'" >&2; exit 2; }
      [[ -f ${2#*=} ]] || { echo "slam_suite.sh: --model ${2%%=*}: no file ${2#*=}" >&2; exit 2; }
      MODELS+=("${2%%=*}=$(cd "$(dirname "${2#*=}")" && pwd)/$(basename "${2#*=}")"); shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "slam_suite.sh: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) POS+=("$1"); shift ;;
  esac
done
# shellcheck source=scripts/bench_common.sh
source "$ROOT/scripts/bench_common.sh"
bench_setup slam_suite.sh

# simulate DIR ARGS...: DATA/DIR with obm-sim ARGS unless it is there (sim_info.yaml written last).
simulate() {
  local dir=$DATA/$1; shift
  if [[ -f $dir/sim_info.yaml ]]; then echo "== $(basename "$dir"): reusing $dir"; return; fi
  echo "== $(basename "$dir"): obm-sim $*"
  rm -rf "$dir"
  nice -n "$NICE" "$SIM" "$@" -o "$dir" -q
}

# turn_frames SEQ N: the first frame of the N sharpest separate turns of SEQ (yaw rate from the
# ground truth, turns at least 100 frames apart), in frame order.
turn_frames() {
  python3 - "$1/poses.txt" "$2" << 'PY'
import math, sys
yaw = []
for line in open(sys.argv[1]):
    v = [float(x) for x in line.split()]
    # camera frame (z forward, x right): heading of the optical axis in the x-z plane
    yaw.append(math.atan2(v[2], v[10]))
rate = [abs(math.remainder(yaw[i + 5] - yaw[i], 2 * math.pi)) for i in range(len(yaw) - 5)]
picked = []
for i in sorted(range(len(rate)), key=lambda i: -rate[i]):
    if i > 50 and all(abs(i - j) >= 100 for j in picked):
        picked.append(i)
    if len(picked) == int(sys.argv[2]):
        break
print(' '.join(str(i) for i in sorted(picked)))
PY
}

# run_map NAME SEQ obm-map-args...
run_map() {
  local name=$1 seq=$2; shift 2
  local dir=$OUT/runs/$name
  if [[ $RESUME -eq 1 && -f $dir/metrics.json && -f $dir/timing.json ]]; then
    echo "== $name: kept (--resume)"; return
  fi
  rm -rf "$dir"
  echo "== $name: obm-map -c $CFG -i $seq $*"
  mkdir -p "$(dirname "$dir")"
  # KITTI folders are scored on poses.txt; RGB-D folders on their own groundtruth.txt.
  local gt=()
  [[ -d $seq/velodyne ]] && gt=(-g "$seq/poses.txt")
  echo "obm-map -c $CFG -i $seq ${gt[*]} --no-map $* ${SETS[*]}" > "$OUT/runs/$name.command.txt"
  nice -n "$NICE" "$MAP" -c "$CFG" -i "$seq" "${gt[@]}" --no-map "$@" "${SETS[@]}" \
    -o "$dir" -q > "$OUT/runs/$name.log" 2>&1 ||
    { echo "slam_suite.sh: obm-map failed for $name (see $OUT/runs/$name.log)" >&2; exit 1; }
  mv "$OUT/runs/$name.command.txt" "$dir/command.txt"
}

both() {  # both LABEL SEQ: the ICP-only and the OBMNet pipeline(s)
  run_map "$1.icp" "$2" --matcher icp
  run_map "$1.obmnet" "$2"
  local m
  [[ -d $2/velodyne ]] || return 0  # --model networks are LiDAR ones
  for m in "${MODELS[@]+"${MODELS[@]}"}"; do
    run_map "$1.obmnet_${m%%=*}" "$2" --set "matcher.obmnet.model_path=${m#*=}"
  done
}

if want corridor; then
  simulate corridor -c "$ROOT/config/sim/suite_corridor.yaml"
  both corridor "$DATA/corridor"
fi
if want open_road; then
  simulate open_road -c "$ROOT/config/sim/suite_open_road.yaml"
  both open_road "$DATA/open_road"
fi
if want urban || want turn_gaps || want turn_jumps || want long_gaps; then
  simulate urban_s$SEED -p kitti_like_urban -s "$SEED"
  want urban && both urban "$DATA/urban_s$SEED"
  read -r t1 t2 t3 <<< "$(turn_frames "$DATA/urban_s$SEED" 3)"
  if want turn_gaps && [[ ! -f $DATA/turn_gaps/times.txt ]]; then
    rm -rf "$DATA/turn_gaps"
    python3 "$ROOT/scripts/drop_sweeps.py" "$DATA/urban_s$SEED" "$DATA/turn_gaps" \
      --drop "$t1:10" "$t2:20" "$t3:30"
  fi
  if want turn_jumps && [[ ! -f $DATA/turn_jumps/times.txt ]]; then
    rm -rf "$DATA/turn_jumps"
    python3 "$ROOT/scripts/drop_sweeps.py" "$DATA/urban_s$SEED" "$DATA/turn_jumps" \
      --drop "$t1:10" "$t2:10" "$t3:10" --hide-gaps
  fi
  if want long_gaps && [[ ! -f $DATA/long_gaps/times.txt ]]; then
    rm -rf "$DATA/long_gaps"
    python3 "$ROOT/scripts/drop_sweeps.py" "$DATA/urban_s$SEED" "$DATA/long_gaps" \
      --drop "$t1:40" "$t2:50" "$t3:60"
  fi
  want turn_gaps && both turn_gaps "$DATA/turn_gaps"
  want turn_jumps && both turn_jumps "$DATA/turn_jumps"
  want long_gaps && both long_gaps "$DATA/long_gaps"
fi
if want revisits || want revisit_gaps; then
  simulate revisits -p urban_revisits -s "$SEED"
  want revisits && both revisits "$DATA/revisits"
  if want revisit_gaps && [[ ! -f $DATA/revisit_gaps/times.txt ]]; then
    read -r r1 r2 r3 <<< "$(turn_frames "$DATA/revisits" 3)"
    rm -rf "$DATA/revisit_gaps"
    python3 "$ROOT/scripts/drop_sweeps.py" "$DATA/revisits" "$DATA/revisit_gaps" \
      --drop "$r1:40" "$r2:50" "$r3:60"
  fi
  want revisit_gaps && both revisit_gaps "$DATA/revisit_gaps"
fi
if want offset_revisits; then
  simulate offset_revisits -c "$ROOT/config/sim/suite_offset_revisits.yaml"
  both offset_revisits "$DATA/offset_revisits"
fi

if want indoor_walk; then
  simulate indoor_walk -p indoor_loop -s "$SEED"
  CFG=$ICFG both indoor_walk "$DATA/indoor_walk"
fi
if want indoor_fast; then
  simulate indoor_fast -c "$ROOT/config/sim/suite_indoor_fast.yaml"
  CFG=$ICFG both indoor_fast "$DATA/indoor_fast"
fi
if want indoor_plain; then
  simulate indoor_plain -c "$ROOT/config/sim/suite_indoor_plain.yaml"
  CFG=$ICFG both indoor_plain "$DATA/indoor_plain"
fi

python3 "$ROOT/scripts/slam_suite_table.py" "$OUT" > "$OUT/table.md.tmp"
mv "$OUT/table.md.tmp" "$OUT/table.md"
echo "== table: $OUT/table.md"
cat "$OUT/table.md"
