#!/usr/bin/env bash
# Data-parallel obm-train (docs/training.md, "Several processes") on loopback:
#   check_obm_train_dist.sh <obm-train binary> <source root> <scratch folder>
# - `--nproc 2`: one run, two processes; rank 0 writes the run's files, rank 1 its log;
# - the run resumes with another world size (one process);
# - a rank killed (SIGKILL) mid-epoch: the launcher and the other rank exit with a clear error in
#   bounded time, and `--resume` continues from the last whole epoch;
# - bad environments and devices are clear errors.
# Needs the CGAL meshes (skipped, exit 77, without them, except in CI).
set -euo pipefail
tool="$1"
root="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
cgal_meshes_or_skip
rm -rf "$work"
mkdir -p "$work"
cd "$work"
small=(-c "$root/config/obmnet/train_objects.yaml" --data "$meshes" --threads 1 --batch-size 2
       --set model.emb_dims=32 --set model.n_samples=8 --set model.n_keypoints=64
       --set train.val_pairs=2 --set train.curriculum_epochs=0)

# Two processes, one epoch.
"$tool" "${small[@]}" -o run --nproc 2 --epochs 1 --set train.pairs_per_epoch=4 > log1.txt 2>&1 ||
  { cat log1.txt run/rank_1.log; fail "--nproc 2 run"; }
for f in checkpoint.pt best.pt train_log.csv config.yaml rank_1.log; do
  [[ -s run/$f ]] || fail "run/$f missing after the two-process run"
done
grep -q 'rank 0 of 2' log1.txt || { cat log1.txt; fail "rank 0 did not report joining"; }
grep -q 'rank 1 of 2' run/rank_1.log || { cat run/rank_1.log; fail "rank 1 did not log to rank_1.log"; }
grep -q 'comm_ms_per_step' run/train_log.csv || fail "train_log.csv: no comm_ms_per_step column"

# Resumed by one process (another world size).
"$tool" -c run/config.yaml -o run --resume --epochs 2 > log2.txt 2>&1 || { cat log2.txt; fail "resume with one process"; }
grep -q 'resuming after epoch 1' log2.txt || { cat log2.txt; fail "did not resume after epoch 1"; }
[[ $(grep -c '^[0-9]' run/train_log.csv) -eq 2 ]] || fail "train_log.csv: expected 2 epoch rows"

# A rank killed mid-epoch: epochs of 40 pairs (20 steps of ~0.1 s), killed once the first epoch is
# in the checkpoint. The collective timeout is short so that a hang would show as a failure here.
export OBM_DIST_TIMEOUT=60
"$tool" "${small[@]}" -o kill --nproc 2 --epochs 50 --set train.pairs_per_epoch=40 > log3.txt 2>&1 &
launcher=$!
for _ in $(seq 600); do [[ -s kill/checkpoint.pt ]] && break; sleep 0.2; done
[[ -s kill/checkpoint.pt ]] || { kill $launcher; cat log3.txt; fail "no checkpoint after the first epoch"; }
rank1=""
for p in $(pgrep -P $launcher); do
  tr '\0' '\n' < /proc/$p/environ | grep -qx 'RANK=1' && rank1=$p
done
[[ -n $rank1 ]] || { kill $launcher; fail "rank 1 not found among the launcher's children"; }
kill -KILL "$rank1"
t0=$SECONDS
set +e
wait $launcher
rc=$?
set -e
(( SECONDS - t0 < 90 )) || fail "the run took $((SECONDS - t0)) s to stop after a rank was killed"
[[ $rc -ne 0 ]] || { cat log3.txt; fail "a run that lost a rank must fail"; }
grep -q 'rank 1 exited' log3.txt || { cat log3.txt; fail "the launcher must name the rank that died"; }
grep -q 'distributed training: rank 0 of 2' log3.txt || { cat log3.txt; fail "rank 0 must say the collective failed"; }
done_epochs=$(grep -c '^[0-9]' kill/train_log.csv)
(( done_epochs >= 1 )) || fail "the killed run kept no epoch"
"$tool" -c kill/config.yaml -o kill --resume --nproc 2 --epochs $((done_epochs + 1)) > log4.txt 2>&1 ||
  { cat log4.txt; fail "resume after the killed rank"; }
grep -q "resuming after epoch $done_epochs" log4.txt || { cat log4.txt; fail "did not resume after epoch $done_epochs"; }
unset OBM_DIST_TIMEOUT

# Bad input.
if RANK=3 WORLD_SIZE=2 "$tool" "${small[@]}" -o bad > bad1.txt 2>&1; then fail "RANK >= WORLD_SIZE must fail"; fi
grep -q 'RANK=3' bad1.txt || { cat bad1.txt; fail "the error must name RANK"; }
if "$tool" "${small[@]}" -o bad --device cuda:0 > bad2.txt 2>&1; then fail "--device cuda:0 on a CPU build must fail"; fi
grep -q 'train.device' bad2.txt || { cat bad2.txt; fail "the error must name train.device"; }
if "$tool" "${small[@]}" -o bad --device tpu > bad3.txt 2>&1; then fail "--device tpu must fail"; fi
echo "obm-train data-parallel: ok"
