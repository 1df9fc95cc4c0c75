#!/usr/bin/env bash
# Faults: obm-sim, obm-map and obm-train killed by SIGINT, SIGTERM and SIGKILL at random points,
# an output folder on a full file system, and input sweeps that vanish or are unreadable.
#   check_faults.sh <bin folder> <source tree> <scratch folder>
# What must hold (docs/obm-map.md, docs/obm-sim.md, docs/training.md):
#  - every output file that exists is complete and readable (written atomically), whatever the
#    signal; SIGINT / SIGTERM exit with 130 after writing what was processed (obm-map) or leave
#    nothing (obm-sim, whose folder appears whole or not at all); a SIGKILLed obm-map keeps the
#    trajectories of its last autosave (output.autosave_s);
#  - a training killed by SIGKILL and resumed logs the very numbers of an uninterrupted run;
#  - a full disk is a clear error naming the file and the system's reason, exit code 1, and no
#    half-written file is left;
#  - a missing or truncated sweep is reported with its frame and bridged.
# The kill times are drawn from a fixed seed and printed. The full-disk cases need a small tmpfs
# (mount, root); without that permission they are skipped with a message. The training cases need
# the CGAL meshes (skipped without them, except in CI).
set -euo pipefail
bin="$1"
src="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
umount "$work/full" 2> /dev/null || true  # left mounted by an earlier run that was killed
rm -rf "$work"
mkdir -p "$work"
cd "$src"
RANDOM=2207  # the kill times below repeat from run to run

# ---------------------------------------------------------------------------------------------
# Checks of an output folder: every file that exists is whole.
check_json() { python3 -c 'import json,sys; json.load(open(sys.argv[1]))' "$1" 2> /dev/null || fail "$1: not valid JSON"; }
check_fields() {  # FILE N: every line that is not a comment has N fields
  local bad
  bad=$(awk -v n="$2" '!/^#/ && NF != n { c++ } END { print c + 0 }' "$1")
  [[ "$bad" -eq 0 ]] || fail "$1: $bad line(s) without $2 fields (a half-written file?)"
}
check_png() {  # the PNG signature and the IEND chunk that ends every whole PNG
  head -c 8 "$1" | od -An -tx1 | tr -d ' \n' | grep -q '^89504e470d0a1a0a$' || fail "$1: not a PNG"
  tail -c 12 "$1" | grep -q IEND || fail "$1: truncated PNG (no IEND)"
}
check_map_outputs() {  # DIR: whatever obm-map left there is complete
  local d="$1" f
  for f in "$d"/*; do
    [[ -e "$f" ]] || continue
    [[ -s "$f" ]] || fail "$f: empty output file"
    case "$f" in
      *.json) check_json "$f" ;;
      */trajectory_tum.txt|*/keyframes_tum.txt) check_fields "$f" 8 ;;
      */trajectory_kitti.txt) check_fields "$f" 12 ;;
      */frames.csv) python3 -c 'import csv, sys
w = {len(r) for r in csv.reader(l for l in open(sys.argv[1]) if not l.startswith("#"))}
sys.exit(len(w) > 1)' "$f" || fail "$f: rows of different widths" ;;
      *.png) check_png "$f" ;;
      *.svg|*.html) tail -c 200 "$f" | grep -q '</svg>\|</html>' || fail "$f: truncated" ;;
      */map.bt) head -1 "$f" | grep -q '^# Octomap OcTree binary file' || fail "$f: not an OctoMap file" ;;
      */graph.g2o) "$bin/obm-graph" -i "$f" -o "$work/check.g2o" --report "$work/check.json" \
                     > /dev/null 2>&1 || fail "$f: obm-graph cannot read it" ;;
    esac
  done
}
temporaries() { find "$1" -maxdepth 1 -name '.*.tmp.*' 2> /dev/null | wc -l; }
# wait_for GLOB: until a path matching GLOB exists (the app is past its start-up, its signal
# handler installed). Needed because a background job of a script starts with SIGINT ignored:
# a signal sent before the app installs its handler would be lost, not tested.
wait_for() {
  for _ in $(seq 300); do compgen -G "$1" > /dev/null && return 0; sleep 0.05; done
  fail "nothing matching $1 appeared within 15 s"
}

# A short simulated drive shared by the obm-map cases (90 sweeps, ~90 m).
seq="$work/seq"
"$bin/obm-sim" --preset kitti_like_urban --frames 90 --seed 5 --out "$seq" --quiet --log-level warn
ls "$seq/velodyne" | grep -c '\.bin$' | grep -qx 90 || fail "sim: 90 sweeps expected"

# ---------------------------------------------------------------------------------------------
# obm-sim killed: the output folder appears whole or not at all.
for sig in INT TERM KILL; do
  delay=$(awk -v r=$RANDOM 'BEGIN { printf "%.2f", 0.5 + 2.5 * r / 32767 }')
  out="$work/sim_$sig"
  "$bin/obm-sim" --preset kitti_like_urban --frames 60 --seed 6 --out "$out" --quiet --log-level error &
  pid=$!
  wait_for "$out.tmp-*"
  sleep "$delay"
  kill -s "$sig" "$pid" 2> /dev/null || true
  set +e; wait "$pid"; rc=$?; set -e
  echo "obm-sim SIG$sig ${delay} s into the run: exit $rc"
  if [[ $rc -eq 0 ]]; then  # finished before the signal: whole
    [[ $(ls "$out/velodyne" | wc -l) -eq 60 && -s "$out/poses.txt" ]] || fail "obm-sim exit 0 but $out incomplete"
    continue
  fi
  [[ ! -e "$out" ]] || fail "obm-sim SIG$sig: $out exists after an interrupted run"
  case $sig in
    INT|TERM) [[ $rc -eq 130 ]] || fail "obm-sim SIG$sig: exit $rc, expected 130"
              ls -d "$out".tmp-* > /dev/null 2>&1 && fail "obm-sim SIG$sig left its temporary folder" ;;
    KILL) # a killed process cannot clean up: its temporary folder stays, and a new run still works
          "$bin/obm-sim" --preset kitti_like_urban --frames 5 --seed 6 --out "$out" --quiet --log-level error \
            || fail "obm-sim after a SIGKILL: a new run into $out failed"
          [[ $(ls "$out/velodyne" | wc -l) -eq 5 ]] || fail "obm-sim rerun after SIGKILL incomplete" ;;
  esac
done

# ---------------------------------------------------------------------------------------------
# obm-map killed at random points.
for sig in INT TERM KILL INT TERM KILL; do
  delay=$(awk -v r=$RANDOM 'BEGIN { printf "%.2f", 0.5 + 5.5 * r / 32767 }')
  out="$work/map_${sig}_$RANDOM"
  # Trajectories saved every 0.5 s (output.autosave_s; 60 s by default): what a SIGKILL leaves.
  "$bin/obm-map" -c config/map_kitti.yaml -i "$seq" -o "$out" -q --log-level error \
    --set output.autosave_s=0.5 > "$out.log" 2>&1 &
  pid=$!
  wait_for "$out"
  # SIGKILL: the kill lands after the first autosave (how long the first frames take depends on
  # the machine's load), so what it leaves can be checked.
  if [[ $sig == KILL ]]; then wait_for "$out/trajectory_tum.txt"; fi
  sleep "$delay"
  kill -s "$sig" "$pid" 2> /dev/null || true
  set +e; wait "$pid"; rc=$?; set -e
  echo "obm-map SIG$sig ${delay} s into the run: exit $rc, $(ls "$out" 2> /dev/null | wc -l) file(s), $(temporaries "$out") temporary"
  [[ -d "$out" ]] && check_map_outputs "$out"
  case $sig in
    INT|TERM)
      [[ $rc -eq 130 || $rc -eq 0 ]] || { cat "$out.log"; fail "obm-map SIG$sig: exit $rc, expected 130"; }
      # Exit 0 only when the run had ended: then every frame was processed.
      [[ $rc -eq 130 || $(num frames "$out/metrics.json") -eq 90 ]] || fail "obm-map SIG$sig ignored"
      # What was processed is written: the trajectory has one pose per processed frame.
      check_json "$out/metrics.json"
      frames=$(num frames "$out/metrics.json")
      [[ $(grep -vc '^#' "$out/trajectory_tum.txt") -eq $frames ]] || fail "obm-map SIG$sig: trajectory_tum.txt is not $frames poses"
      if [[ $rc -eq 130 ]]; then
        grep -q '"interrupted": *true' "$out/metrics.json" || fail "obm-map SIG$sig: metrics.json must say interrupted"
      fi
      [[ $(temporaries "$out") -eq 0 ]] || fail "obm-map SIG$sig left temporary files" ;;
    KILL) [[ $rc -eq 137 || $rc -eq 0 ]] || fail "obm-map SIGKILL: exit $rc"
          # Killed after an autosave: the last one holds the poses of the frames before, whole.
          if [[ $rc -eq 137 ]]; then
            [[ -s "$out/trajectory_tum.txt" && -s "$out/trajectory_kitti.txt" ]] \
              || fail "obm-map SIGKILL after ${delay} s: no autosaved trajectory"
            echo "  autosaved: $(grep -vc '^#' "$out/trajectory_tum.txt") poses"
          fi ;;
  esac
done

# ---------------------------------------------------------------------------------------------
# Input sweeps that vanished (a dangling link) or are truncated: reported by frame, bridged.
bad="$work/seq_bad"
mkdir -p "$bad/velodyne"
for f in calib.txt times.txt poses.txt; do ln -s "$seq/$f" "$bad/$f"; done
for f in "$seq"/velodyne/*.bin; do ln -s "$f" "$bad/velodyne/$(basename "$f")"; done
rm "$bad/velodyne/000030.bin"; ln -s "$work/vanished.bin" "$bad/velodyne/000030.bin"
rm "$bad/velodyne/000041.bin"; head -c 1000 "$seq/velodyne/000041.bin" > "$bad/velodyne/000041.bin"
"$bin/obm-map" -c config/map_kitti.yaml -i "$bad" -o "$work/map_bad" -q > "$work/map_bad.log" 2>&1 \
  || { tail "$work/map_bad.log"; fail "obm-map must go on past unreadable sweeps"; }
grep -q 'frame 30: cannot read' "$work/map_bad.log" || { cat "$work/map_bad.log"; fail "the vanished sweep must be reported with its frame"; }
grep -q 'frame 41: .*not a multiple of 16' "$work/map_bad.log" || fail "the truncated sweep must be reported with its frame"
[[ $(num read_errors "$work/map_bad/metrics.json") -eq 2 ]] || fail "metrics.json: read_errors must be 2"
[[ $(grep -vc '^#' "$work/map_bad/trajectory_tum.txt") -eq 90 ]] || fail "every frame keeps a pose"
lt "$(num ate_rmse_m "$work/map_bad/metrics.json")" 0.3 || fail "two bridged sweeps must not break the run"
check_map_outputs "$work/map_bad"
echo "unreadable sweeps: reported by frame, bridged, ATE $(num ate_rmse_m "$work/map_bad/metrics.json") m"

# ---------------------------------------------------------------------------------------------
# A full file system (a 300 KiB tmpfs): a clear error, exit 1, no half-written file.
full="$work/full"
mkdir -p "$full"
if mount -t tmpfs -o size=300k tmpfs "$full" 2> /dev/null; then
  trap 'umount "$full" 2> /dev/null || true' EXIT
  set +e
  "$bin/obm-map" -c config/map_kitti.yaml -i "$seq" -o "$full/out" -q > "$work/full_map.log" 2>&1
  rc=$?
  set -e
  [[ $rc -eq 1 ]] || { cat "$work/full_map.log"; fail "obm-map on a full disk: exit $rc, expected 1"; }
  grep -q "cannot write '$full/out/.*No space left on device" "$work/full_map.log" \
    || { cat "$work/full_map.log"; fail "the error must name the file and the system's reason"; }
  check_map_outputs "$full/out"
  [[ $(temporaries "$full/out") -eq 0 ]] || fail "a temporary file was left on the full disk"
  echo "full disk, obm-map: $(grep -o "cannot write.*" "$work/full_map.log" | head -1)"
  if [[ -x "$bin/obm-train" ]] && ls "${OBM_CGAL_DATA:-$HOME/.cache/obmslam/cgal/data/meshes}"/*.off > /dev/null 2>&1; then
    rm -rf "$full/out"
    set +e
    "$bin/obm-train" -c config/obmnet/train_objects.yaml -o "$full/train" --epochs 1 --threads 1 \
      --batch-size 2 --set model.emb_dims=32 --set model.n_samples=8 --set model.n_keypoints=64 \
      --set train.pairs_per_epoch=2 --set train.val_pairs=2 --set train.curriculum_epochs=0 \
      > "$work/full_train.log" 2>&1
    rc=$?
    set -e
    [[ $rc -eq 1 ]] || { cat "$work/full_train.log"; fail "obm-train on a full disk: exit $rc, expected 1"; }
    grep -q "$full/train/" "$work/full_train.log" || { cat "$work/full_train.log"; fail "obm-train: the error must name the file"; }
    [[ $(find "$full/train" -name '.*.tmp.*' | wc -l) -eq 0 ]] || fail "obm-train left a temporary file on the full disk"
    echo "full disk, obm-train: $(grep -o "error: .*" "$work/full_train.log" | head -1)"
  fi
  umount "$full"
  trap - EXIT
else
  echo "SKIP (part): cannot mount a tmpfs here (needs root); the full-disk cases did not run"
fi

# ---------------------------------------------------------------------------------------------
# obm-train killed by SIGKILL in its second epoch and resumed: the log holds the numbers of the
# uninterrupted run (the pairs, the Gumbel noise and the optimiser state are restored exactly).
cgal_meshes_or_skip
small=(--threads 1 --batch-size 2 --set model.emb_dims=32 --set model.n_samples=8
       --set model.n_keypoints=64 --set train.pairs_per_epoch=16 --set train.val_pairs=2
       --set train.curriculum_epochs=0 --data "$meshes")
"$bin/obm-train" -c config/obmnet/train_objects.yaml -o "$work/train_straight" --epochs 3 "${small[@]}" \
  > "$work/train_straight.log" 2>&1 || { tail "$work/train_straight.log"; fail "uninterrupted training"; }
"$bin/obm-train" -c config/obmnet/train_objects.yaml -o "$work/train_killed" --epochs 3 "${small[@]}" \
  > "$work/train_killed.log" 2>&1 &
pid=$!
for _ in $(seq 600); do  # until epoch 1 is in the log, then a little into epoch 2
  n=$(cat "$work/train_killed/train_log.csv" 2> /dev/null | grep -c '^[0-9]' || true)
  [[ ${n:-0} -ge 1 ]] && break
  sleep 0.1
done
delay=$(awk -v r=$RANDOM 'BEGIN { printf "%.2f", 0.2 + 1.0 * r / 32767 }')
sleep "$delay"
kill -KILL "$pid" 2> /dev/null || true
set +e; wait "$pid"; rc=$?; set -e
echo "obm-train SIGKILL ${delay} s into epoch 2: exit $rc, $(grep -c '^[0-9]' "$work/train_killed/train_log.csv") epoch(s) logged"
"$bin/obm-train" -c "$work/train_killed/config.yaml" -o "$work/train_killed" --resume \
  > "$work/train_resumed.log" 2>&1 || { tail "$work/train_resumed.log"; fail "resumed training"; }
# Columns 1–11 (epoch … val_mean_alpha) and loss_pose; wall time, pairs/s and comm differ.
cols() { awk -F, 'NR > 1 { print $1","$2","$3","$4","$5","$6","$7","$8","$9","$10","$11","$16 }' "$1"; }
diff <(cols "$work/train_straight/train_log.csv") <(cols "$work/train_killed/train_log.csv") \
  || fail "the resumed training's log differs from the uninterrupted run's"
[[ $(cols "$work/train_killed/train_log.csv" | wc -l) -eq 3 ]] || fail "3 epochs expected"
echo "faults: ok"
