#!/usr/bin/env bash
# obm-o3d-odometry (Open3D's RGB-D odometry, the indoor peer of scripts/bench_slam.sh) on the 5 real
# frames of shared/data/rgbd_open3d, and its errors on bad input:
#   check_obm_o3d_odometry.sh <obm-o3d-odometry binary> <source folder> <scratch folder>
# The data is read in place from $OBM_SHARED_DATA (default: ../shared/data beside the checkout);
# without it the test is skipped (exit 77), except in CI (CI=true), where that fails.
set -euo pipefail
tool="$1"
src="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
rm -rf "$work"
mkdir -p "$work"

"$tool" --help > "$work/help.txt" || fail "--help"
grep -q -- "--method" "$work/help.txt" || fail "--help does not list --method"

# Bad input first (needs no data): a missing folder is named, exit code 1, nothing written.
missing="$work/no_such_sequence"
if "$tool" -i "$missing" -o "$work/out_missing" -q 2> "$work/missing.err"; then
  fail "a missing input folder was accepted"
fi
grep -q "$missing" "$work/missing.err" || fail "missing folder not named: $(cat "$work/missing.err")"
[[ ! -e $work/out_missing/trajectory_tum.txt ]] || fail "a failed run wrote a trajectory"

data="${OBM_SHARED_DATA:-$src/../shared/data}/rgbd_open3d"
if [[ ! -f $data/trajectory.log ]]; then
  [[ "${CI:-}" == "true" ]] && fail "reference data missing in CI: $data (set OBM_SHARED_DATA)"
  echo "SKIP: reference data not found: $data (set OBM_SHARED_DATA to the shared/data folder)"
  exit 77
fi

if "$tool" -i "$data" -o "$work/out_bad_method" -m nope -q 2> "$work/method.err"; then
  fail "an unknown --method was accepted"
fi
grep -q "nope" "$work/method.err" || fail "unknown method not named: $(cat "$work/method.err")"

# A frame whose colour image is not an image: the run carries on without it, names the frame and
# the file, leaves it out of the trajectory and lists it in metrics.json.
bad="$work/bad_color"
mkdir -p "$bad/depth" "$bad/color"
for f in "$data"/depth/*.png; do ln -s "$f" "$bad/depth/$(basename "$f")"; done
for f in "$data"/color/*.jpg; do ln -s "$f" "$bad/color/$(basename "$f")"; done
rm "$bad/color/00002.jpg"
echo "not a JPEG" > "$bad/color/00002.jpg"
ln -s "$data/camera_primesense.json" "$bad/camera_primesense.json"
ln -s "$data/trajectory.log" "$bad/trajectory.log"
"$tool" -i "$bad" -o "$work/out_bad" -q > "$work/bad.log" 2> "$work/bad.err" ||
  { cat "$work/bad.err"; fail "a sequence with one unreadable colour image stopped"; }
grep -q "frame 2" "$work/bad.err" || fail "skipped frame not named: $(cat "$work/bad.err")"
grep -q "color/00002.jpg" "$work/bad.err" || fail "bad file not named: $(cat "$work/bad.err")"
[[ $(grep -cv '^#' "$work/out_bad/trajectory_tum.txt") -eq 4 ]] || fail "skipped frame: not 4 poses"
[[ $(num skipped "$work/out_bad/metrics.json") -eq 1 ]] || fail "metrics.json: skipped != 1"
grep -A2 '"skipped_frames"' "$work/out_bad/metrics.json" | grep -qw 2 || fail "skipped_frames lacks 2"
# The 4 poses are scored against the ground truth of their own frames (0, 1, 3, 4): measured
# 0.0006 m; paired by position instead (frame 3 with the truth of frame 2) the ATE is centimetres.
[[ $(num frames_evaluated "$work/out_bad/metrics.json") -eq 4 ]] || fail "skipped frame: not 4 frames evaluated"
lt "$(num ate_rmse_m "$work/out_bad/metrics.json")" 0.002 || fail "skipped frame: ATE above 0.002 m"

# Every colour image unreadable: exit code 1 naming the first frame, no trajectory.
for f in "$bad"/color/*.jpg; do rm "$f"; echo "not a JPEG" > "$f"; done
if "$tool" -i "$bad" -o "$work/out_none" -q 2> "$work/none.err"; then
  fail "a sequence with no readable frame was accepted"
fi
grep -q "none of its 5 frame(s) could be read" "$work/none.err" || fail "no-frame error: $(cat "$work/none.err")"
grep -q "frame 0" "$work/none.err" || fail "no-frame error does not name frame 0"
[[ ! -e $work/out_none/trajectory_tum.txt ]] || fail "a run with no frame wrote a trajectory"

# ate_vs_log TRAJ_TUM LOG: ATE RMSE [m] of a TUM trajectory against a Redwood trajectory.log (pose
# k = item k) after the rigid alignment (Horn's quaternion method, eigenvectors by Jacobi rotations).
ate_vs_log() {
  python3 - "$1" "$2" << 'PY'
import math, sys
est = [[float(x) for x in l.split()[1:4]] for l in open(sys.argv[1]) if l.strip() and not l.startswith('#')]
rows = [l.split() for l in open(sys.argv[2]) if l.strip()]
gt = [[float(rows[5 * k + 1 + r][3]) for r in range(3)] for k in range(len(rows) // 5)]
n = min(len(est), len(gt))
P, Q = est[:n], gt[:n]
mp = [sum(p[a] for p in P) / n for a in range(3)]
mq = [sum(q[a] for q in Q) / n for a in range(3)]
S = [[sum((P[i][a] - mp[a]) * (Q[i][b] - mq[b]) for i in range(n)) for b in range(3)] for a in range(3)]
(xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = S
N = [[xx + yy + zz, yz - zy, zx - xz, xy - yx],
     [yz - zy, xx - yy - zz, xy + yx, zx + xz],
     [zx - xz, xy + yx, yy - xx - zz, yz + zy],
     [xy - yx, zx + xz, yz + zy, zz - xx - yy]]
# cyclic Jacobi rotations until N is diagonal; V collects the eigenvectors as columns
V = [[float(i == j) for j in range(4)] for i in range(4)]
for _ in range(60):
    if sum(N[i][j] ** 2 for i in range(4) for j in range(4) if i != j) < 1e-30:
        break
    for p in range(3):
        for r in range(p + 1, 4):
            if N[p][r] == 0.0:
                continue
            th = 0.5 * math.atan2(2.0 * N[p][r], N[r][r] - N[p][p])
            c, s = math.cos(th), math.sin(th)
            for M in (N, V):  # columns p, r
                for k in range(4):
                    M[k][p], M[k][r] = c * M[k][p] - s * M[k][r], s * M[k][p] + c * M[k][r]
            for k in range(4):  # rows p, r of N
                N[p][k], N[r][k] = c * N[p][k] - s * N[r][k], s * N[p][k] + c * N[r][k]
best = max(range(4), key=lambda k: N[k][k])
w, x, y, z = (V[k][best] for k in range(4))
R = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
e2 = 0.0
for i in range(n):
    p = [P[i][a] - mp[a] for a in range(3)]
    e2 += sum((sum(R[a][b] * p[b] for b in range(3)) + mq[a] - Q[i][a]) ** 2 for a in range(3))
print(f'{math.sqrt(e2 / n):.6f}')
PY
}

# The real frames: 5 poses, ATE against trajectory.log below the bound of each method. Measured
# with Open3D 0.16 (Debian 12, 2 cores): hybrid 0.00037 m, colored_icp 0.0097 m (the obm-map of
# config/map_indoor.yaml: 0.0005 m). The bounds are about 2x that, the hybrid one rounded up to
# 1 mm. For scale: the camera moves 9.8 cm over the 5 frames, and 5 identical poses score 0.035 m.
for spec in "hybrid 0.001" "colored_icp 0.02"; do
  read -r method bound <<< "$spec"
  out="$work/out_$method"
  "$tool" -i "$data" -o "$out" -m "$method" -q > "$work/$method.log" 2>&1 ||
    { cat "$work/$method.log"; fail "$method: obm-o3d-odometry failed"; }
  traj="$out/trajectory_tum.txt"
  [[ -s $traj && -s $out/metrics.json ]] || fail "$method: outputs missing"
  lines=$(grep -cv '^#' "$traj")
  [[ $lines -eq 5 ]] || fail "$method: $lines poses in trajectory_tum.txt, expected 5"
  [[ $(num frames "$out/metrics.json") -eq 5 ]] || fail "$method: metrics.json frames != 5"
  num failures "$out/metrics.json" > /dev/null
  num frames_per_second "$out/metrics.json" > /dev/null
  grep -q "\"method\": \"$method\"" "$out/metrics.json" || fail "$method: metrics.json method"
  ate=$(ate_vs_log "$traj" "$data/trajectory.log") || fail "$method: scoring failed"
  lt "$ate" "$bound" || fail "$method: ATE $ate m vs trajectory.log, bound $bound m"
  echo "$method: ATE $ate m (bound $bound m)"
done

# -n limits the frames.
"$tool" -i "$data" -o "$work/out_n3" -n 3 -q > /dev/null 2>&1 || fail "-n 3 failed"
[[ $(grep -cv '^#' "$work/out_n3/trajectory_tum.txt") -eq 3 ]] || fail "-n 3: not 3 poses"
echo "obm-o3d-odometry command line: OK"
