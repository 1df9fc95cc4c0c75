#!/usr/bin/env bash
# The obm-map and obm-octomap command lines exactly as documented (and as the acceptance checks
# call them), on a short simulated KITTI-layout sequence:
#   check_obm_map_cli.sh <bin folder> <source tree> <scratch folder>
set -euo pipefail
bin="$1"
src="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
rm -rf "$work"
mkdir -p "$work"
cd "$src"   # config/map_kitti.yaml is given relative to the checkout, as in the README

"$bin/obm-map" --help >/dev/null || fail "obm-map --help"
"$bin/obm-octomap" --help >/dev/null || fail "obm-octomap --help"

# 110 sweeps (~107 m): long enough for the devkit's 100 m segments.
seq="$work/seq"
"$bin/obm-sim" --preset kitti_like_urban --frames 110 --seed 5 --out "$seq" --quiet --log-level warn
for f in calib.txt times.txt poses.txt velodyne/000109.bin; do [[ -s "$seq/$f" ]] || fail "sim: $f"; done

out="$work/out"
"$bin/obm-map" --config config/map_kitti.yaml --input "$seq" --gt "$seq/poses.txt" --out "$out" \
  > "$work/map.log" 2>&1 || { tail -20 "$work/map.log"; fail "obm-map failed"; }
for f in metrics.json timing.json trajectory_kitti.txt trajectory_tum.txt graph.g2o map.bt; do
  [[ -s "$out/$f" ]] || fail "obm-map: missing $out/$f"
done
for k in t_err_percent r_err_deg_per_100m ate_rmse_m loops_accepted; do num "$k" "$out/metrics.json" >/dev/null; done
for k in frames wall_s frames_per_second; do num "$k" "$out/timing.json" >/dev/null; done
[[ $(num frames "$out/timing.json") -eq 110 ]] || fail "timing.json: frames must be 110"
# Every input frame has a pose, in the input's camera-frame convention (12 numbers per line).
[[ $(grep -c . "$out/trajectory_kitti.txt") -eq 110 ]] || fail "trajectory_kitti.txt: 110 poses expected"
[[ $(awk '{print NF}' "$out/trajectory_kitti.txt" | sort -u) == "12" ]] || fail "trajectory_kitti.txt: 12 numbers per line"
[[ $(awk '!/^#/ {print NF}' "$out/trajectory_tum.txt" | sort -u) == "8" ]] || fail "trajectory_tum.txt: 8 columns per line"
# A clean simulated drive: far inside the targets; a broken pipeline is metres off.
lt "$(num t_err_percent "$out/metrics.json")" 1.0 || fail "t_err $(num t_err_percent "$out/metrics.json") %"
lt "$(num ate_rmse_m "$out/metrics.json")" 0.3 || fail "ATE $(num ate_rmse_m "$out/metrics.json") m"
head -1 "$out/map.bt" | grep -q '^# Octomap OcTree binary file' || fail "map.bt is not an OctoMap binary file"
# The pose graph is readable by obm-graph.
"$bin/obm-graph" -i "$out/graph.g2o" -o "$work/graph_opt.g2o" --report "$work/graph.json" \
  > /dev/null 2>&1 || fail "obm-graph cannot read obm-map's graph.g2o"

# obm-octomap from the sequence and obm-map's trajectory.
"$bin/obm-octomap" --input "$seq" --trajectory "$out/trajectory_kitti.txt" --resolution 0.2 \
  --out "$work/map.bt" > "$work/octomap.log" 2>&1 || { tail -20 "$work/octomap.log"; fail "obm-octomap failed"; }
head -1 "$work/map.bt" | grep -q '^# Octomap OcTree binary file' || fail "obm-octomap: not an OctoMap binary file"
grep -q 'res 0.2' "$work/map.bt" || fail "obm-octomap: resolution 0.2 not in the header"

# Bad input: clear errors naming the key / folder, exit code 1, nothing written.
if "$bin/obm-map" --config config/map_kitti.yaml --input "$seq" --out "$work/bad" \
     --set no_such.key=1 2> "$work/bad.err"; then fail "unknown config key accepted"; fi
grep -q 'no_such' "$work/bad.err" || fail "unknown key not named: $(cat "$work/bad.err")"
[[ ! -e "$work/bad" ]] || fail "a failed run left $work/bad"
if "$bin/obm-map" --config config/map_kitti.yaml --input "$work/no_such_seq" --out "$work/bad" \
     2> "$work/bad.err"; then fail "missing input accepted"; fi
grep -q 'no_such_seq' "$work/bad.err" || fail "missing input not named: $(cat "$work/bad.err")"
[[ ! -e "$work/bad" ]] || fail "a failed run left $work/bad"
head -c 100 "$seq/poses.txt" > "$work/short_poses.txt"
if "$bin/obm-octomap" --input "$seq" --trajectory "$work/short_poses.txt" --out "$work/bad.bt" \
     2> "$work/bad.err"; then fail "truncated trajectory accepted"; fi
grep -q 'short_poses.txt' "$work/bad.err" || fail "bad trajectory not named: $(cat "$work/bad.err")"
[[ ! -e "$work/bad.bt" ]] || fail "a failed run wrote $work/bad.bt"
# Lost sweeps (scripts/drop_sweeps.py): four sweeps removed at frame 60 with the time stamps
# rewritten, so the guess falls ~4 m short. Every kept sweep still gets a pose, the jump is not
# silently tracked, and the trajectory stays right.
jump="$work/jump"
python3 scripts/drop_sweeps.py "$seq" "$jump" --drop 60:4 --hide-gaps > /dev/null || fail "drop_sweeps.py"
[[ $(ls "$jump/velodyne" | wc -l) -eq 106 && $(grep -c . "$jump/times.txt") -eq 106 &&
   $(grep -c . "$jump/poses.txt") -eq 106 ]] || fail "drop_sweeps.py: 106 sweeps, stamps and poses expected"
cmp -s "$jump/velodyne/000060.bin" "$seq/velodyne/000064.bin" || fail "drop_sweeps.py: sweep 60 must be the input's 64"
"$bin/obm-map" --config config/map_kitti.yaml --input "$jump" --out "$work/jump_out" --no-map -q \
  > "$work/jump.log" 2>&1 || { tail -20 "$work/jump.log"; fail "obm-map on lost sweeps failed"; }
[[ $(grep -c . "$work/jump_out/trajectory_kitti.txt") -eq 106 ]] || fail "lost sweeps: 106 poses expected"
status60=$(awk -F, '$1 == 60 {print $3}' "$work/jump_out/frames.csv")
[[ "$status60" == recovered || "$status60" == bridged ]] || fail "the sweep after the jump was '$status60'"
lt "$(num ate_rmse_m "$work/jump_out/metrics.json")" 0.3 || fail "lost sweeps: ATE $(num ate_rmse_m "$work/jump_out/metrics.json") m"
if python3 scripts/drop_sweeps.py "$seq" "$work/bad_drop" --drop 60 2> "$work/bad.err"; then
  fail "drop_sweeps.py accepted --drop 60"; fi
grep -q "FIRST:COUNT" "$work/bad.err" || fail "drop_sweeps.py: bad --drop not explained: $(cat "$work/bad.err")"
if python3 scripts/drop_sweeps.py "$seq" "$jump" --drop 1:1 2> "$work/bad.err"; then
  fail "drop_sweeps.py wrote into an existing folder"; fi
echo "obm-map / obm-octomap command lines: OK"
