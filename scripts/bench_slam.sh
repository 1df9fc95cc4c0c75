#!/usr/bin/env bash
# Accuracy and speed of obm-map on simulated sequences: the "SLAM (obm-map)" table of
# docs/benchmarks.md.
#
#   scripts/bench_slam.sh [options] DATA_DIR OUT_DIR
#
# DATA_DIR holds the simulated sequences; any that is missing is generated with obm-sim:
#   urban_full  obm-sim -p kitti_like_urban -s SEED             (1900 sweeps, 1.6 km, loops)
#   k00         obm-sim -p kitti00_gt -s SEED -n K00_FRAMES     (needs OBM_SHARED_DATA: KITTI 00 poses)
#   fr1xyz      obm-sim -p indoor_tum_fr1_xyz -s SEED -n 400    (needs OBM_SHARED_DATA: TUM poses)
#   fr2desk     obm-sim -p indoor_tum_fr2_desk -s SEED -n 600
#   office      obm-sim -p indoor_loop -s SEED            (a 35 m walk through an office floor:
#               rooms, doors, a corridor, back to the start)
# A folder that exists is reused when its sim_info.yaml names the same preset, seed and frames.
# OUT_DIR/runs/NAME/ gets obm-map's outputs plus load.txt (uptime before and after the run) and
# the command; OUT_DIR/mrpt/ the MRPT icp-slam comparison; OUT_DIR/table.md the Markdown table.
# The indoor part runs every sequence three ways (the configuration as shipped; NAME_icp, the
# ICP-only pipeline, --matcher icp; NAME_geometric, colour and depth-noise terms off), adds the whole
# real TUM sequence $OBM_SHARED_DATA/tum/rgbd_dataset_freiburg1_rpy (fr1rpy, read in place), and
# runs Open3D's classical RGB-D odometry (bin/obm-o3d-odometry, built when Open3D is found;
# --method hybrid and colored_icp) on each into OUT_DIR/runs/SEQ_o3d_METHOD/, and obm-map and both
# peers on the 5 real frames of $OBM_SHARED_DATA/rgbd_open3d (ground truth trajectory.log) into
# OUT_DIR/runs/rgbd_open3d*/; the table's "indoor RGB-D" part scores all of them from their
# trajectory_tum.txt (ATE after rigid alignment, RPE over 1 frame) and lists obm-map's loops with
# the number its own check against the truth calls wrong (> 0.5 m or 2°).
# The LiDAR parts (urban, k00) also run KISS-ICP, the LiDAR odometry most users would pick instead
# (../shared/peers/kiss_icp, built into OUT_DIR/peers/kiss_icp; its defaults but de-skewing and the
# 0.205° KITTI vertical-angle correction, both off: simulated sweeps have neither), on the same KITTI
# folders into OUT_DIR/runs/NAME_kiss/ (poses_kitti.txt, camera-0 poses as poses.txt); the table's
# "beside KISS-ICP" part scores it and obm-map's runs by the same code (KITTI devkit, ATE).
#
# Options:
#   --build DIR         build folder with bin/obm-map and bin/obm-sim      [default: ROOT/build]
#   --only LIST         comma-separated subset of: urban,k00,indoor,mrpt,suite
#                       [default: urban,k00,indoor,mrpt]; suite = scripts/slam_suite.sh (the
#                       robustness suite, ICP-only and OBMNet pipelines) into DATA_DIR/suite and
#                       OUT_DIR/suite
#                       (`--only table` runs nothing and rebuilds the table from OUT_DIR)
#   --k00-frames N      frames of kitti00_gt (the preset stops at 1000)    [default: 1000]
#   --seed S            obm-sim master seed of every sequence              [default: 5]
#   --mrpt-frames N     prefix of the urban rawlog given to icp-slam       [default: 600]
#   --indoor-config F   configuration of the indoor runs           [default: config/map_indoor.yaml]
#                       (NAME_icp and NAME_geometric override it as described above)
#   --o3d-methods LIST  Open3D peers of the indoor part, comma-separated [default: hybrid,colored_icp]
#   --nice N            niceness of every run                              [default: 5]
#   --peers DIR         third-party peers (kiss_icp/)          [default: ROOT/../shared/peers]
#   --resume            keep runs that already have their results in OUT_DIR (an interrupted
#                       benchmark goes on where it stopped; the table is rebuilt from all runs)
#
# Speed figures are wall-clock and depend on what else runs on the machine: load.txt records the
# load average before and after each run and the table prints it next to frames/s.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$ROOT/build
ONLY=urban,k00,indoor,mrpt
K00_FRAMES=1000
MRPT_FRAMES=600
FR1_FRAMES=400
FR2_FRAMES=600
O3D_METHODS=hybrid,colored_icp
INDOOR_CFG=$ROOT/config/map_indoor.yaml
NICE=5
SEED=5
RESUME=0
PEERS=$ROOT/../shared/peers

usage() { awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; }
POS=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --build) BUILD=$(cd "$2" && pwd); shift 2 ;;
    --only) ONLY=$2; shift 2 ;;
    --k00-frames) K00_FRAMES=$2; shift 2 ;;
    --mrpt-frames) MRPT_FRAMES=$2; shift 2 ;;
    --indoor-config) INDOOR_CFG=$(cd "$(dirname "$2")" && pwd)/$(basename "$2"); shift 2 ;;
    --nice) NICE=$2; shift 2 ;;
    --o3d-methods) O3D_METHODS=$2; shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --peers) PEERS=$(cd "$2" && pwd); shift 2 ;;
    --resume) RESUME=1; shift ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "bench_slam.sh: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) POS+=("$1"); shift ;;
  esac
done
# shellcheck source=scripts/bench_common.sh
source "$ROOT/scripts/bench_common.sh"
bench_setup bench_slam.sh
load1() { cut -d' ' -f1 /proc/loadavg; }
O3D=$BUILD/bin/obm-o3d-odometry

# ensure_seq DIR PRESET FRAMES: simulate DATA/DIR unless it exists with the same preset, seed and
# length (FRAMES 0 = the preset's).
ensure_seq() {
  local dir=$DATA/$1 preset=$2 frames=$3
  if [[ -f $dir/sim_info.yaml ]]; then
    local have_preset have_seed have_frames
    have_preset=$(sed -n 's/^preset: //p' "$dir/sim_info.yaml")
    have_seed=$(sed -n 's/^seed: //p' "$dir/sim_info.yaml")
    have_frames=$(sed -n 's/^frames: //p' "$dir/sim_info.yaml")
    if [[ $have_preset == "$preset" && $have_seed == "$SEED" &&
          ($frames -eq 0 || $have_frames -eq $frames) ]]; then
      echo "== $1: reusing $dir ($preset, seed $SEED, $have_frames frames)"
      return
    fi
    echo "bench_slam.sh: $dir holds $have_preset seed $have_seed ($have_frames frames)," \
      "want $preset seed $SEED (frames $frames); remove it first" >&2
    exit 1
  fi
  echo "== $1: simulating ($preset, seed $SEED)"
  local n=()
  if [[ $frames -gt 0 ]]; then n=(-n "$frames"); fi
  nice -n "$NICE" "$SIM" -p "$preset" -s "$SEED" "${n[@]}" -o "$dir" -q
}

# run_tool NAME TOOL BINARY DONE_FILE args...: one run of TOOL (BINARY args -o OUT/runs/NAME -q)
# with the load around it; --resume keeps a run whose metrics.json and DONE_FILE exist.
run_tool() {
  local name=$1 tool=$2 bin=$3 done_file=$4; shift 4
  local dir=$OUT/runs/$name
  if [[ $RESUME -eq 1 && -f $dir/metrics.json && -f $dir/$done_file ]]; then
    echo "== $name: kept (--resume)"
    return
  fi
  mkdir -p "$dir"
  echo "$tool $*" > "$dir/command.txt"
  echo "== $name: $tool $*"
  { echo "before: $(uptime)"; } > "$dir/load.txt"
  # sample the 1-min load average every 10 s while the run lasts
  ( while true; do load1; sleep 10; done ) > "$dir/load_samples.txt" &
  local sampler=$!
  local rc=0
  rm -f "$dir/failed.txt"
  nice -n "$NICE" "$bin" "$@" -o "$dir" -q 2> "$dir/stderr.txt" || rc=$?
  kill "$sampler" 2>/dev/null || true
  wait "$sampler" 2>/dev/null || true
  echo "after:  $(uptime)" >> "$dir/load.txt"
  # A failed run is a result too: it is named in the table (failed.txt: the exit code and the
  # last line of its stderr.txt) and the benchmark goes on.
  if [[ $rc -ne 0 ]]; then
    echo "exit $rc: $(tail -n 1 "$dir/stderr.txt")" > "$dir/failed.txt"
    echo "bench_slam.sh: $tool failed for $name ($(cat "$dir/failed.txt"))" >&2
  fi
}

# run_map NAME obm-map-args...: one obm-map run into OUT/runs/NAME with the load around it.
run_map() { local name=$1; shift; run_tool "$name" obm-map "$MAP" timing.json "$@"; }

# run_peer NAME METHOD INPUT: obm-o3d-odometry --method METHOD on INPUT into OUT/runs/NAME.
# Open3D's loops are OpenMP; the tool shortens their threads' spin itself, as obm-map does
# (docs/obm-o3d-odometry.md), so a busy second core does not slow it down.
run_peer() {
  run_tool "$1" obm-o3d-odometry "$O3D" trajectory_tum.txt -i "$3" --method "$2"
}

# run_kiss NAME KITTI_DIR: KISS-ICP on a KITTI folder into OUT/runs/NAME/, timed,
# with the load around it as run_tool does. Skipped with a note when the peer is missing.
KISS=""
run_kiss() {
  local name=$1 input=$2 dir=$OUT/runs/$1
  if [[ -z $KISS ]]; then
    if [[ ! -x $PEERS/kiss_icp/build.sh ]]; then
      echo "bench_slam.sh: $PEERS/kiss_icp missing: no KISS-ICP rows" >&2
      return
    fi
    KISS=$("$PEERS/kiss_icp/build.sh" "$OUT/peers/kiss_icp" | tail -n 1)
  fi
  if [[ $RESUME -eq 1 && -f $dir/poses_kitti.txt && -f $dir/wall.txt ]]; then
    echo "== $name: kept (--resume)"
    return
  fi
  mkdir -p "$dir"
  echo "kiss_kitti_driver $input $dir/poses_kitti.txt --deskew 0 --correct 0" > "$dir/command.txt"
  echo "== $name: KISS-ICP on $input"
  echo "before: $(uptime)" > "$dir/load.txt"
  ( while true; do load1; sleep 10; done ) > "$dir/load_samples.txt" &
  local sampler=$! start end
  start=$(date +%s.%N)
  nice -n "$NICE" "$KISS" "$input" "$dir/poses_kitti.txt.tmp" --deskew 0 --correct 0 > "$dir/log.txt" 2>&1 ||
    { kill "$sampler"; echo "bench_slam.sh: KISS-ICP failed for $name" >&2; exit 1; }
  end=$(date +%s.%N)
  kill "$sampler" 2>/dev/null || true
  wait "$sampler" 2>/dev/null || true
  mv "$dir/poses_kitti.txt.tmp" "$dir/poses_kitti.txt"
  echo "after:  $(uptime)" >> "$dir/load.txt"
  echo "$start $end" > "$dir/wall.txt"
}

KITTI_CFG=$ROOT/config/map_kitti.yaml

if want urban; then
  ensure_seq urban_full kitti_like_urban 0
  run_map urban "-c" "$KITTI_CFG" -i "$DATA/urban_full" -g "$DATA/urban_full/poses.txt"
  run_map urban_noloops -c "$KITTI_CFG" -i "$DATA/urban_full" -g "$DATA/urban_full/poses.txt" \
    --no-loops
  run_kiss urban_kiss "$DATA/urban_full"
fi

if want k00; then
  : "${OBM_SHARED_DATA:?kitti00_gt needs OBM_SHARED_DATA (e.g. /work/shared/data)}"
  ensure_seq k00 kitti00_gt "$K00_FRAMES"
  run_map k00 -c "$KITTI_CFG" -i "$DATA/k00" -g "$DATA/k00/poses.txt"
  run_map k00_noloops -c "$KITTI_CFG" -i "$DATA/k00" -g "$DATA/k00/poses.txt" --no-loops
  run_kiss k00_kiss "$DATA/k00"
fi

if want indoor; then
  : "${OBM_SHARED_DATA:?the indoor_tum_* presets need OBM_SHARED_DATA (e.g. /work/shared/data)}"
  ensure_seq fr1xyz indoor_tum_fr1_xyz "$FR1_FRAMES"
  ensure_seq fr2desk indoor_tum_fr2_desk "$FR2_FRAMES"
  ensure_seq office indoor_loop 0
  GEOMETRIC=(--set input.rgbd_color=false --set tracking.icp.color_weight=0
             --set tracking.icp.depth_noise_weights=false)
  # The real TUM sequence: the whole of freiburg1_rpy (Kinect, motion-capture ground truth).
  RPY=$OBM_SHARED_DATA/tum/rgbd_dataset_freiburg1_rpy
  [[ -f $RPY/groundtruth.txt ]] || { echo "bench_slam.sh: $RPY/groundtruth.txt missing" >&2; exit 1; }
  # Each sequence: the configuration as shipped, the ICP-only pipeline (--matcher icp: the network
  # nowhere) and the geometric tracking (colour and depth-noise terms off).
  for seq in fr1xyz fr2desk office fr1rpy; do
    input=$DATA/$seq
    [[ $seq == fr1rpy ]] && input=$RPY
    run_map "$seq" -c "$INDOOR_CFG" -i "$input"
    run_map "${seq}_icp" -c "$INDOOR_CFG" -i "$input" --matcher icp
    run_map "${seq}_geometric" -c "$INDOOR_CFG" -i "$input" "${GEOMETRIC[@]}"
  done
  # The classical peer on the same sequences, and both systems on the 5 real frames of
  # rgbd_open3d (Redwood layout, ground truth trajectory.log, which obm-map reads itself).
  REAL=$OBM_SHARED_DATA/rgbd_open3d
  [[ -f $REAL/trajectory.log ]] || { echo "bench_slam.sh: $REAL/trajectory.log missing" >&2; exit 1; }
  run_map rgbd_open3d -c "$INDOOR_CFG" -i "$REAL"
  if [[ -x $O3D ]]; then
    for method in ${O3D_METHODS//,/ }; do
      for seq in fr1xyz fr2desk office; do run_peer "${seq}_o3d_$method" "$method" "$DATA/$seq"; done
      run_peer "fr1rpy_o3d_$method" "$method" "$RPY"
      run_peer "rgbd_open3d_o3d_$method" "$method" "$REAL"
    done
  else
    echo "bench_slam.sh: $O3D not built (needs Open3D, libopen3d-dev): no Open3D peer rows" >&2
  fi
fi

if want suite; then
  suite_args=(--build "$BUILD" --config "$KITTI_CFG" --seed "$SEED" --nice "$NICE")
  [[ $RESUME -eq 1 ]] && suite_args+=(--resume)
  "$ROOT/scripts/slam_suite.sh" "${suite_args[@]}" "$DATA/suite" "$OUT/suite"
fi

# --- MRPT icp-slam on a prefix of the urban rawlog ----------------------------------------------
# Both systems get the same file: the first MRPT_FRAMES observations of urban_full/sequence.rawlog
# (CObservationPointCloud, sensor pose = vehicle pose) with the matching lines of groundtruth.txt
# (TUM, T_world_lidar, first frame = identity). icp-slam's log_estimated_path.txt has one line
# "step x y yaw" per observation: the planar pose of the vehicle (= the LiDAR) in the map frame,
# which starts at the first vehicle pose; it is lifted to SE(3) with z = roll = pitch = 0 and
# scored against groundtruth.txt by the same devkit / Umeyama code as obm-map's trajectory_tum.txt.
if want mrpt; then
  command -v icp-slam > /dev/null || { echo "bench_slam.sh: icp-slam (mrpt-apps) missing" >&2; exit 1; }
  ensure_seq urban_full kitti_like_urban 0
  M=$OUT/mrpt
  P=$M/urban_prefix
  mkdir -p "$P"
  if [[ ! -f $P/sequence.rawlog ]]; then
    rawlog-edit --cut --to-index $((MRPT_FRAMES - 1)) -i "$DATA/urban_full/sequence.rawlog" \
      -o "$P/sequence.rawlog.tmp" > "$M/rawlog-edit.log" 2>&1
    mv "$P/sequence.rawlog.tmp" "$P/sequence.rawlog"
  fi
  head -n $((MRPT_FRAMES + 1)) "$DATA/urban_full/groundtruth.txt" > "$P/groundtruth.txt"
  run_map urban_prefix -c "$KITTI_CFG" -i "$P/sequence.rawlog" -n "$MRPT_FRAMES"
  run_map urban_prefix_noloops -c "$KITTI_CFG" -i "$P/sequence.rawlog" -n "$MRPT_FRAMES" --no-loops
  # icp-slam empties its logOutput_dir: our own files stay next to it, in $M
  sed "s|^logOutput_dir .*|logOutput_dir = $M/icp_slam|" "$ROOT/config/mrpt/icp_slam_hdl64.ini" \
    > "$M/icp_slam.ini"
  echo "icp-slam $M/icp_slam.ini $P/sequence.rawlog" > "$M/icp_slam_command.txt"
  echo "== icp-slam on $MRPT_FRAMES frames"
  echo "before: $(uptime)" > "$M/icp_slam_load.txt"
  ( while true; do load1; sleep 10; done ) > "$M/icp_slam_load_samples.txt" &
  sampler=$!
  start=$(date +%s.%N)
  nice -n "$NICE" icp-slam "$M/icp_slam.ini" "$P/sequence.rawlog" > "$M/icp_slam.log" 2>&1
  end=$(date +%s.%N)
  kill "$sampler" 2>/dev/null || true
  wait "$sampler" 2>/dev/null || true
  echo "after:  $(uptime)" >> "$M/icp_slam_load.txt"
  echo "$start $end" > "$M/icp_slam_wall.txt"
fi

# --- scoring and the table ------------------------------------------------------------------------
python3 - "$OUT" "$DATA" "$MRPT_FRAMES" "${OBM_SHARED_DATA:-}" > "$OUT/table.md" << 'PY'
import bisect, json, math, os, sys

out, data, mrpt_frames, shared = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]

# ---- small SE(3) helpers (4x4 lists), no numpy ---------------------------------------------------
def mat(R, t):
    return [R[0] + [t[0]], R[1] + [t[1]], R[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]
def mul(A, B):
    return [[sum(A[i][k] * B[k][j] for k in range(4)) for j in range(4)] for i in range(4)]
def inv(T):
    R = [[T[j][i] for j in range(3)] for i in range(3)]
    t = [-sum(R[i][k] * T[k][3] for k in range(3)) for i in range(3)]
    return mat(R, t)
def quat_to_R(qx, qy, qz, qw):
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]

def read_tum(path):
    poses = []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = [float(x) for x in line.split()]
        poses.append(mat(quat_to_R(*v[4:8]), v[1:4]))
    return poses
def read_mrpt_path(path):
    # "step x y yaw": planar pose, lifted to SE(3) with z = roll = pitch = 0
    poses = []
    for line in open(path):
        v = line.split()
        if len(v) < 4:
            continue
        x, y, th = float(v[1]), float(v[2]), float(v[3])
        c, s = math.cos(th), math.sin(th)
        poses.append(mat([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], [x, y, 0.0]))
    return poses

# ---- KITTI devkit t_err / r_err (docs/metrics.md section 2) -------------------------------------
def kitti_errors(gt, est):
    n = min(len(gt), len(est))
    d = [0.0]
    for i in range(1, n):
        d.append(d[-1] + math.dist([gt[i][k][3] for k in range(3)], [gt[i - 1][k][3] for k in range(3)]))
    te, re = [], []
    for f in range(0, n, 10):
        for L in range(100, 900, 100):
            l = next((j for j in range(f, n) if d[j] > d[f] + L), None)
            if l is None:
                continue
            dg = mul(inv(gt[f]), gt[l])
            de = mul(inv(est[f]), est[l])
            E = mul(inv(de), dg)
            c = max(min(0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0), 1.0), -1.0)
            re.append(math.acos(c) / L)
            te.append(math.sqrt(E[0][3] ** 2 + E[1][3] ** 2 + E[2][3] ** 2) / L)
    if not te:
        return None, None
    return 100.0 * sum(te) / len(te), 100.0 * 180.0 / math.pi * sum(re) / len(re)

# ---- ATE after rigid alignment (Horn's closed form = Umeyama without scale) ---------------------
def jacobi_max_eigvec(N):
    A = [row[:] for row in N]
    V = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    for _ in range(100):
        off = sum(A[i][j] ** 2 for i in range(4) for j in range(4) if i != j)
        if off < 1e-22:
            break
        for p in range(4):
            for q in range(p + 1, 4):
                if abs(A[p][q]) < 1e-300:
                    continue
                th = 0.5 * math.atan2(2 * A[p][q], A[q][q] - A[p][p])
                c, s = math.cos(th), math.sin(th)
                for k in range(4):
                    akp, akq = A[k][p], A[k][q]
                    A[k][p], A[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(4):
                    apk, aqk = A[p][k], A[q][k]
                    A[p][k], A[q][k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(4):
                    vkp, vkq = V[k][p], V[k][q]
                    V[k][p], V[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    i = max(range(4), key=lambda k: A[k][k])
    return [V[k][i] for k in range(4)]
def ate(gt, est, dims=3):
    n = min(len(gt), len(est))
    P = [[est[i][k][3] for k in range(3)] for i in range(n)]
    Q = [[gt[i][k][3] for k in range(3)] for i in range(n)]
    if dims == 2:
        P = [[p[0], p[1], 0.0] for p in P]
        Q = [[q[0], q[1], 0.0] for q in Q]
    mp = [sum(p[k] for p in P) / n for k in range(3)]
    mq = [sum(q[k] for q in Q) / n for k in range(3)]
    S = [[sum((P[i][a] - mp[a]) * (Q[i][b] - mq[b]) for i in range(n)) for b in range(3)] for a in range(3)]
    (sxx, sxy, sxz), (syx, syy, syz), (szx, szy, szz) = S
    N = [[sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
         [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
         [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
         [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz]]
    w, x, y, z = jacobi_max_eigvec(N)
    R = quat_to_R(x, y, z, w)
    err2 = 0.0
    for i in range(n):
        p = [P[i][k] - mp[k] for k in range(3)]
        rp = [sum(R[a][b] * p[b] for b in range(3)) for a in range(3)]
        err2 += sum((rp[a] + mq[a] - Q[i][a]) ** 2 for a in range(3))
    return math.sqrt(err2 / n)

# ---- table ---------------------------------------------------------------------------------------
def jload(p):
    return json.load(open(p)) if os.path.exists(p) else None
def load_range(run, s=None):
    s = s or os.path.join(run, 'load_samples.txt')
    v = [float(x) for x in open(s).read().split()] if os.path.exists(s) else []
    return f'{min(v):.1f}–{max(v):.1f}' if v else '?'
def fmt(x, f):
    return '—' if x is None else f.format(x)
def print_table(header, rows, blank_before=True):
    """A Markdown table: the header's cells, then one line per row."""
    if blank_before:
        print()
    print('| ' + ' | '.join(header) + ' |')
    print('|' + '---|' * len(header))
    for r in rows:
        print('| ' + ' | '.join(r) + ' |')
def sim_info(seq):
    info = {}
    p = os.path.join(data, seq, 'sim_info.yaml')
    if os.path.exists(p):
        for line in open(p):
            if ':' in line and not line.startswith('#'):
                k, v = line.split(':', 1)
                info[k.strip()] = v.strip()
    return info

rows = []
runs = {}
def add(name, seq_label, variant, lidar, noloops=None):
    run = os.path.join(out, 'runs', name)
    m, t = jload(os.path.join(run, 'metrics.json')), jload(os.path.join(run, 'timing.json'))
    if m is None or t is None:
        return
    runs[name] = (m, t)
    fps = t['frames_per_second']
    verdict = []
    if lidar and noloops is None:
        pass
    elif lidar:
        ok = lambda c: 'met' if c else '**not met**'
        lim = lambda v, x: 'n/a (no 100 m segment)' if v is None else ok(v <= x)
        verdict.append(f"t_err ≤ 0.2 %: {lim(m['t_err_percent'], 0.2)}")
        verdict.append(f"r_err ≤ 0.1: {lim(m['r_err_deg_per_100m'], 0.1)}")
        verdict.append(f"ATE ≤ 0.3 m: {ok(m['ate_rmse_m'] <= 0.3)}")
        verdict.append(f"≥ 10 frames/s: {ok(fps >= 10.0)}")
        nl = runs.get(noloops)
        if nl and m['loops_accepted'] == 0:
            verdict.append("better than --no-loops: not shown (no loop accepted)")
        elif nl:
            cmp = lambda a, b, what: f"{what} {'better' if a < b else 'equal' if a == b else '**worse**'}"
            verdict.append('vs --no-loops: ' + ', '.join([
                cmp(m['ate_rmse_m'], nl[0]['ate_rmse_m'], 'ATE'),
                cmp(m['t_err_percent'], nl[0]['t_err_percent'], 't_err'),
                cmp(m['r_err_deg_per_100m'], nl[0]['r_err_deg_per_100m'], 'r_err')]))
    else:
        verdict.append(f"ATE ≤ 2 cm: {'met' if m['ate_rmse_m'] <= 0.02 else '**not met**'}")
    rows.append([seq_label, str(m['frames']), f"{m['ground_truth_length_m']:.0f} m" if m['ground_truth_length_m'] >= 10 else f"{m['ground_truth_length_m']:.2f} m",
                 variant, m['matcher'],
                 fmt(m['t_err_percent'], '{:.3f}'), fmt(m['r_err_deg_per_100m'], '{:.3f}'),
                 f"{m['ate_rmse_m']:.3f} m" if lidar else f"{100 * m['ate_rmse_m']:.2f} cm",
                 str(m['loops_accepted']), f"{fps:.1f}", load_range(run), '; '.join(verdict) or 'reference'])

add('urban_noloops', 'kitti_like_urban', 'no loops', True)
add('urban', 'kitti_like_urban', 'loops', True, 'urban_noloops')
add('k00_noloops', 'kitti00_gt', 'no loops', True)
add('k00', 'kitti00_gt', 'loops', True, 'k00_noloops')
add('fr1xyz', 'indoor_tum_fr1_xyz', 'loops', False)
add('fr2desk', 'indoor_tum_fr2_desk', 'loops', False)

print_table(['sequence', 'frames', 'length', 'variant', 'matcher', 't_err [%]', 'r_err [°/100 m]', 'ATE RMSE',
             'loops', 'frames/s (wall)', 'load (1 min)', 'target'], rows, blank_before=False)

# KISS-ICP beside obm-map on the same KITTI folders: every row scored here from its camera-0 poses
# against the folder's poses.txt (KITTI devkit segments, ATE after rigid alignment).
def read_kitti(path):
    poses = []
    for line in open(path):
        v = [float(x) for x in line.split()]
        if len(v) == 12:
            poses.append([v[0:4], v[4:8], v[8:12], [0.0, 0.0, 0.0, 1.0]])
    return poses
kiss_rows = []
for seq, label, base in (('urban_full', 'kitti_like_urban', 'urban'), ('k00', 'kitti00_gt', 'k00')):
    gt_path = os.path.join(data, seq, 'poses.txt')
    if not os.path.exists(gt_path) or not os.path.exists(os.path.join(out, 'runs', f'{base}_kiss', 'poses_kitti.txt')):
        continue
    gt = read_kitti(gt_path)
    for name, system in ((f'{base}_noloops', 'obm-map --no-loops'), (base, 'obm-map (loops)'),
                         (f'{base}_kiss', 'KISS-ICP v1.2.3 (no loop closure)')):
        run = os.path.join(out, 'runs', name)
        if name.endswith('_kiss'):
            est = read_kitti(os.path.join(run, 'poses_kitti.txt'))
            w = open(os.path.join(run, 'wall.txt')).read().split()
            fps = len(est) / (float(w[1]) - float(w[0]))
        else:
            if not os.path.exists(os.path.join(run, 'trajectory_kitti.txt')):
                continue
            est = read_kitti(os.path.join(run, 'trajectory_kitti.txt'))
            t = jload(os.path.join(run, 'timing.json'))
            fps = t['frames_per_second'] if t else None
        n = min(len(gt), len(est))
        te, rr = kitti_errors(gt[:n], est[:n])
        kiss_rows.append((label, str(n), system, fmt(te, '{:.3f}'), fmt(rr, '{:.3f}'),
                          f'{ate(gt[:n], est[:n]):.3f} m', fmt(fps, '{:.1f}'), load_range(run)))
if kiss_rows:
    print_table(['LiDAR drive, beside KISS-ICP', 'frames', 'system', 't_err [%]', 'r_err [°/100 m]', 'ATE RMSE',
                 'frames/s (wall)', 'load (1 min)'], kiss_rows)

# MRPT comparison on the same rawlog prefix, all rows scored by this script in the LiDAR frame.
P = os.path.join(out, 'mrpt', 'urban_prefix')
if os.path.exists(os.path.join(P, 'groundtruth.txt')):
    gt = read_tum(os.path.join(P, 'groundtruth.txt'))
    print()
    print('| system (same rawlog, first %d sweeps) | frames | length | t_err [%%] | r_err [°/100 m] | ATE RMSE 3D | ATE RMSE x-y | loops | frames/s (wall) | load (1 min) | obm-map (loops) better? |' % mrpt_frames)
    print('|---|---|---|---|---|---|---|---|---|---|---|')
    length = sum(math.dist([gt[i][k][3] for k in range(3)], [gt[i - 1][k][3] for k in range(3)]) for i in range(1, len(gt)))
    scored = []
    for name, label in (('urban_prefix', 'obm-map, loops'), ('urban_prefix_noloops', 'obm-map --no-loops')):
        run = os.path.join(out, 'runs', name)
        if not os.path.exists(os.path.join(run, 'trajectory_tum.txt')):
            continue
        est = read_tum(os.path.join(run, 'trajectory_tum.txt'))
        m, t = jload(os.path.join(run, 'metrics.json')), jload(os.path.join(run, 'timing.json'))
        te, rr = kitti_errors(gt, est)
        scored.append((label, len(est), te, rr, ate(gt, est), ate(gt, est, 2), str(m['loops_accepted']),
                       f"{t['frames_per_second']:.1f}", load_range(run)))
        # cross-check: this script and obm-map's own evaluation must agree
        if m['ate_rmse_m'] and abs(m['ate_rmse_m'] - ate(gt, est)) > 1e-3 * max(1.0, m['ate_rmse_m']):
            print(f'<!-- warning: ATE {ate(gt, est):.5f} here vs {m["ate_rmse_m"]:.5f} in metrics.json -->')
    path = os.path.join(out, 'mrpt', 'icp_slam', 'log_estimated_path.txt')
    if os.path.exists(path):
        est = read_mrpt_path(path)
        w = open(os.path.join(out, 'mrpt', 'icp_slam_wall.txt')).read().split()
        fps = len(est) / (float(w[1]) - float(w[0]))
        te, rr = kitti_errors(gt, est)
        scored.append(('MRPT icp-slam (config/mrpt/icp_slam_hdl64.ini)', len(est), te, rr, ate(gt, est),
                       ate(gt, est, 2), '— (none)', f'{fps:.2f}',
                       load_range(None, os.path.join(out, 'mrpt', 'icp_slam_load_samples.txt'))))
    ref = scored[0] if scored else None
    for s in scored:
        better = ''
        if ref and s is not ref:
            if (ref[2], ref[3], round(ref[4], 6)) == (s[2], s[3], round(s[4], 6)):
                better = 'equal'
            else:
                better = 'yes' if (ref[4] < s[4] and (ref[2] or 0) < (s[2] or 1e9)) else '**no**'
        print(f'| {s[0]} | {s[1]} | {length:.0f} m | {fmt(s[2], "{:.3f}")} | {fmt(s[3], "{:.3f}")} | {s[4]:.3f} m | {s[5]:.3f} m | {s[6]} | {s[7]} | {s[8]} | {better or "(reference)"} |')

# ---- indoor RGB-D: obm-map against Open3D's classical RGB-D odometry ------------------------------
# Every row is scored here from its trajectory_tum.txt (camera optical frame, depth time stamps):
# poses associated with the ground truth by nearest time stamp (< 0.02 s, as obm-map does for TUM
# folders; rgbd_open3d: pose k = item k of trajectory.log, frame k at k/30 s as libs/io stamps it),
# ATE RMSE after the rigid alignment above, RPE between consecutive associated frames
# (E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j), RMSE of |t(E)| and of angle(E), as libs/eval and obm-map's
# metrics.json). The ATE is checked against each run's own metrics.json.
def read_tum_stamped(path):
    rows = []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = [float(x) for x in line.replace(',', ' ').split()]
        rows.append((v[0], mat(quat_to_R(*v[4:8]), v[1:4])))
    return rows
def read_redwood_log(path):
    lines = [l.split() for l in open(path) if l.strip()]
    return [[[float(x) for x in lines[5 * k + 1 + r]] for r in range(4)] for k in range(len(lines) // 5)]
def associate(est, gt, max_dt=0.02):
    gt_t = [t for t, _ in gt]
    order = sorted(range(len(gt_t)), key=lambda i: gt_t[i])
    st = [gt_t[i] for i in order]
    pairs = []
    for t, T in est:
        k = bisect.bisect_left(st, t)
        best = min((c for c in (k - 1, k) if 0 <= c < len(st)), key=lambda c: abs(st[c] - t), default=None)
        if best is not None and abs(st[best] - t) < max_dt:
            pairs.append((gt[order[best]][1], T))
    return [p[0] for p in pairs], [p[1] for p in pairs]
def rpe1(gt, est):
    te, re = [], []
    for i in range(len(gt) - 1):
        E = mul(inv(mul(inv(gt[i]), gt[i + 1])), mul(inv(est[i]), est[i + 1]))
        te.append(E[0][3] ** 2 + E[1][3] ** 2 + E[2][3] ** 2)
        c = max(min(0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0), 1.0), -1.0)
        re.append(math.degrees(math.acos(c)) ** 2)
    if not te:
        return None, None
    return math.sqrt(sum(te) / len(te)), math.sqrt(sum(re) / len(re))
def map_label(run):
    words = open(os.path.join(run, 'command.txt')).read().split()
    cfg = words[words.index('-c') + 1] if '-c' in words else '?'
    return f'obm-map ({os.path.basename(cfg)})'

PEERS = (('hybrid', 'Open3D RGB-D odometry (hybrid)'),
         ('colored_icp', 'Open3D coloured ICP (frame to frame)'))
indoor = []
for seq, label, gt_file in (('fr1xyz', 'indoor_tum_fr1_xyz (sim)', os.path.join(data, 'fr1xyz', 'groundtruth.txt')),
                            ('fr2desk', 'indoor_tum_fr2_desk (sim)', os.path.join(data, 'fr2desk', 'groundtruth.txt')),
                            ('office', 'indoor_loop, office floor (sim)', os.path.join(data, 'office', 'groundtruth.txt')),
                            ('fr1rpy', 'TUM freiburg1_rpy (real, whole)',
                             os.path.join(shared, 'tum', 'rgbd_dataset_freiburg1_rpy', 'groundtruth.txt') if shared else ''),
                            ('rgbd_open3d', 'rgbd_open3d (shared data, 5 frames)',
                             os.path.join(shared, 'rgbd_open3d', 'trajectory.log') if shared else '')):
    if not gt_file or not os.path.exists(gt_file):
        continue
    if gt_file.endswith('.log'):
        gt = [(k / 30.0, T) for k, T in enumerate(read_redwood_log(gt_file))]
    else:
        gt = read_tum_stamped(gt_file)
    for name, system in [(seq, None), (f'{seq}_icp', None), (f'{seq}_geometric', None)] + [(f'{seq}_o3d_{m}', lab) for m, lab in PEERS]:
        run = os.path.join(out, 'runs', name)
        traj = os.path.join(run, 'trajectory_tum.txt')
        m = jload(os.path.join(run, 'metrics.json'))
        failed = os.path.join(run, 'failed.txt')
        if os.path.exists(failed):
            what = system or (map_label(run) + (', geometric tracking' if name.endswith('_geometric') else ', --matcher icp' if name.endswith('_icp') else ''))
            indoor.append((label, '—', what, '**run failed**: ' + open(failed).read().strip().replace('|', '/')[:160],
                           '—', '—', '—', '—', '—', load_range(run)))
            continue
        if m is None or not os.path.exists(traj):
            continue
        est = read_tum_stamped(traj)
        g, e = associate(est, gt)
        if len(g) < 3:
            continue
        a = ate(g, e)
        rt, rr = rpe1(g, e)
        if system is None:
            t = jload(os.path.join(run, 'timing.json'))
            # obm-map's counterpart of a failed estimate: a frame bridged by the motion model
            fps, system = t['frames_per_second'] if t else None, map_label(run)
            if name.endswith('_geometric'):
                system += ', geometric tracking (no colour, no depth-noise weights)'
            elif name.endswith('_icp'):
                system += ', --matcher icp (no network)'
            failures = f"{m['frames_bridged']} bridged" if 'frames_bridged' in m else '—'
            # loops accepted, and how many of them obm-map's own check against the truth calls wrong
            loops = f"{m.get('loops_accepted', 0)} ({m.get('loops_wrong', 0)} wrong)" if m.get('loops_checked') is not None else '—'
        else:
            fps, failures = m['frames_per_second'], str(m['failures'])
            if m.get('skipped'):
                failures += f", {m['skipped']} skipped"
            loops = '—'
        if m.get('ate_rmse_m') is not None and abs(m['ate_rmse_m'] - a) > 1e-3 * max(0.01, m['ate_rmse_m']):
            print(f'<!-- warning: {name}: ATE {a:.5f} here vs {m["ate_rmse_m"]:.5f} in metrics.json -->')
        indoor.append((label, str(len(est)), system, f'{100 * a:.2f} cm', fmt(rt and 100 * rt, '{:.3f} cm'),
                       fmt(rr, '{:.3f}°'), failures, loops, fmt(fps, '{:.1f}'), load_range(run)))
if indoor:
    print_table(['indoor RGB-D sequence', 'frames', 'system', 'ATE RMSE', 'RPE (1 frame) trans', 'RPE (1 frame) rot',
                 'odometry failures', 'loops (wrong)', 'frames/s (wall)', 'load (1 min)'], indoor)
PY
echo "== table: $OUT/table.md"
cat "$OUT/table.md"
