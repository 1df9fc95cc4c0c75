#!/usr/bin/env bash
# The obm-train command line as documented in docs/training.md: a short run, its output folder,
# and a resumed run driven only by the configuration the first run recorded (OUT/config.yaml):
#   check_obm_train_cli.sh <obm-train binary> <source root> <scratch folder>
# Needs the CGAL meshes (OBM_CGAL_DATA or scripts/get_cgal_meshes.sh's cache); skipped (exit 77)
# when they are not there, except in CI, where that fails.
set -euo pipefail
tool="$1"
root="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
cgal_meshes_or_skip
rm -rf "$work"
mkdir -p "$work"
cd "$work"

"$tool" --help >/dev/null || fail "--help"

# A small network and few pairs, so that one epoch takes seconds. The folder name of --data has a
# ': ' in it, which `--set data.dir=...` would read as a YAML map: the option is recorded as text.
ln -s "$meshes" "meshes: all"
small=(--set model.emb_dims=32 --set model.n_samples=8 --set model.n_keypoints=64
       --set train.pairs_per_epoch=4 --set train.val_pairs=2 --set train.curriculum_epochs=0)
"$tool" -c "$root/config/obmnet/train_objects.yaml" -o run --data "$work/meshes: all" \
  --epochs 1 --threads 1 --batch-size 2 "${small[@]}" > log1.txt 2>&1 || { cat log1.txt; fail "first run"; }
for f in checkpoint.pt best.pt train_log.csv config.yaml; do
  [[ -s run/$f ]] || fail "run/$f missing after the first run"
done
[[ $(grep -c '^[0-9]' run/train_log.csv) -eq 1 ]] || fail "train_log.csv: expected 1 epoch row"

# config.yaml holds the whole configuration as run: model, train and data, the --set values and
# the command-line options among them.
cfg=run/config.yaml
grep -q '^model:' $cfg && grep -q '^train:' $cfg && grep -q '^data:' $cfg || {
  cat $cfg; fail "config.yaml must hold the model, train and data sections"; }
grep -q 'emb_dims: 32' $cfg || fail "config.yaml: --set model.emb_dims=32 not recorded"
grep -q 'epochs: 1$' $cfg || fail "config.yaml: --epochs 1 not recorded"
grep -q 'batch_size: 2$' $cfg || fail "config.yaml: --batch-size 2 not recorded"
grep -q "meshes: all" $cfg || fail "config.yaml: --data not recorded"

# Resume from the recorded file alone, one more epoch: the first epoch's row is kept, the second
# appended, the same data and network (a wrong section would fail to load the checkpoint).
"$tool" -c $cfg -o run --resume --epochs 2 > log2.txt 2>&1 || { cat log2.txt; fail "resumed run"; }
grep -q 'resuming after epoch 1' log2.txt || { cat log2.txt; fail "did not resume after epoch 1"; }
grep -q 'objects:' log2.txt || fail "resumed run did not read the meshes of the recorded data.dir"
[[ $(grep -c '^[0-9]' run/train_log.csv) -eq 2 ]] || fail "train_log.csv: expected 2 epoch rows"
grep -q 'epochs: 2$' $cfg || fail "config.yaml of the resumed run must record --epochs 2"

# --validate scores the trained model on the validation pairs and exits; the log has the column.
"$tool" -c $cfg -o run_val --init run/best.pt --validate > log3.txt 2>&1 || { cat log3.txt; fail "--validate"; }
grep -Eq '^validation: MIE\(R\) [0-9.]+ deg .*inlier ratio [0-9.]+' log3.txt || {
  cat log3.txt; fail "--validate must print MIE(R) and the inlier ratio"; }
[[ ! -e run_val/train_log.csv ]] || fail "--validate must not train"
head -1 run/train_log.csv | grep -q 'val_inlier_ratio' || fail "train_log.csv: no val_inlier_ratio column"

# Self-training (docs/training.md): --validate also scores the teacher's labels; the log has the
# correspondence term; a weight without the teacher's settings is refused, naming the key.
"$tool" -c "$root/config/obmnet/train_objects_selftrain.yaml" -o run_st --data "$work/meshes: all" \
  --epochs 1 --threads 1 --batch-size 2 "${small[@]}" --set model.k1=8 > log4.txt 2>&1 || {
  cat log4.txt; fail "self-training run"; }
head -1 run_st/train_log.csv | grep -q 'loss_match,teacher_labelled' || fail "train_log.csv: no loss_match column"
"$tool" -c run_st/config.yaml -o run_st_val --init run_st/best.pt --validate > log5.txt 2>&1 || {
  cat log5.txt; fail "--validate (self-training)"; }
grep -Eq '^self-training teacher on these pairs: labels [0-9.]+ .* [0-9.]+ of them correct' log5.txt || {
  cat log5.txt; fail "--validate must score the teacher's labels"; }
set +e
"$tool" -c "$root/config/obmnet/train_objects.yaml" -o run_bad --set train.match_loss_weight=1 > bad0.txt 2>&1
rc=$?
set -e
[[ $rc -ne 0 ]] && grep -q 'match_loss_weight' bad0.txt || { cat bad0.txt; fail "match_loss_weight without a teacher must fail naming the key"; }

# Bad input: a misspelt key names the file and the key; a missing config is a clear error.
set +e
"$tool" -c $cfg -o run2 --set train.lr_stepz=3 > bad1.txt 2>&1
rc=$?
set -e
[[ $rc -ne 0 ]] || fail "a misspelt key must fail"
grep -q 'lr_stepz' bad1.txt || { cat bad1.txt; fail "the error must name the misspelt key"; }
if "$tool" -c does_not_exist.yaml -o run3 > bad2.txt 2>&1; then fail "a missing config must fail"; fi
echo "obm-train command line: ok"
