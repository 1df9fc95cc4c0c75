#!/usr/bin/env bash
# Fuzzes every reader of user input with libFuzzer (clang, AddressSanitizer + UBSan) and prints a
# table: executions, coverage, crashes. Docs: docs/testing.md, "Fuzzing".
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET=60] [TARGETS="ply pcd off_obj kitti trajectories png jpeg hdf5 rawlog graph yaml model"]
#   scripts/fuzz.sh runs:N [TARGETS]   # N executions per target (e.g. runs:10000000), timed
#   scripts/fuzz.sh ci        # CI: a fixed number of runs from the seeds alone, fixed seed
#                             # (deterministic: a clean run here is a clean run in CI)
#
# Builds ./build-fuzz ($OBM_FUZZ_BUILD to choose another folder; CXX=clang++, -DOBM_FUZZ=ON, no LibTorch, no apps);
# the `model` target (OBMNet model files) needs LibTorch and is built in ./build-fuzz-torch (the
# network library under clang + ASan: ~15 min of build on 2 cores, so not in the CI run, where the
# test ModelFile.EveryCorruptionLoadsOrIsAFormatErrorNamingTheFile sweeps damaged models instead). Seed corpora come from
# the real files of ../shared/data (or $OBM_SHARED_DATA), the project's configs and a few files
# written here; the corpora grow in build-fuzz/corpus/<target>/ across runs. A crash leaves its
# input in build-fuzz/findings/<target>/ and makes the script exit 1.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECS=${1:-60}
# In CI, rawlogs are left out: MRPT's deserializer sizes strings and vectors from the lengths
# stored in the file, so random bytes make it allocate gigabytes before it fails (it then fails
# cleanly: tests/io, FuzzFindingHugeStringLengthIsAFormatError). Fuzz them by hand, with time.
if [[ $SECS == ci ]]; then
  TARGETS=${2:-"ply pcd off_obj kitti trajectories png jpeg hdf5 graph yaml"}
else
  TARGETS=${2:-"ply pcd off_obj kitti trajectories png jpeg hdf5 rawlog graph yaml model"}
fi
BUILD="${OBM_FUZZ_BUILD:-$ROOT/build-fuzz}"
# -O1 -g1: what a sanitizer's stack trace needs, at about half the compile time of -O2 -g; the
# fuzzers still reach millions of executions per target.
FUZZ_FLAGS=("-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG")
source "$ROOT/scripts/ccache_env.sh"
DATA="${OBM_SHARED_DATA:-$ROOT/../shared/data}"
command -v clang++ > /dev/null || { echo "fuzz.sh: clang++ not found (apt-get install clang)" >&2; exit 1; }
if [[ ! -f "$BUILD/CMakeCache.txt" ]]; then
  mkdir -p "$BUILD"
  CC=clang CXX=clang++ cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "${FUZZ_FLAGS[@]}" -DOBM_FUZZ=ON -DOBM_WITH_TORCH=OFF -DOBM_BUILD_APPS=OFF -DOBM_BUILD_TESTS=OFF > "$BUILD/configure.log" 2>&1 ||
    { cat "$BUILD/configure.log"; exit 1; }
fi
PLAIN=$(for t in $TARGETS; do [[ $t == model ]] || printf 'fuzz_%s ' "$t"; done)
[[ -z $PLAIN ]] || cmake --build "$BUILD" -j"${OBM_JOBS:-$(nproc)}" --target $PLAIN
BUILD_TORCH="$BUILD-torch"
if [[ " $TARGETS " == *" model "* ]]; then
  if [[ ! -f "$BUILD_TORCH/CMakeCache.txt" ]]; then
    mkdir -p "$BUILD_TORCH"
    CC=clang CXX=clang++ cmake -S "$ROOT" -B "$BUILD_TORCH" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "${FUZZ_FLAGS[@]}" -DOBM_FUZZ=ON -DOBM_WITH_TORCH=ON -DOBM_BUILD_APPS=OFF -DOBM_BUILD_TESTS=OFF > "$BUILD_TORCH/configure.log" 2>&1 ||
      { cat "$BUILD_TORCH/configure.log"; exit 1; }
  fi
  cmake --build "$BUILD_TORCH" -j"${OBM_JOBS:-$(nproc)}" --target fuzz_model
fi
fuzzer() { if [[ $1 == model ]]; then echo "$BUILD_TORCH/tests/fuzz/fuzz_model"; else echo "$BUILD/tests/fuzz/fuzz_$1"; fi; }

# seed DIR FILES...: copies the first 64 kB of each existing file into the corpus folder.
seed() {
  local dir=$1; shift
  mkdir -p "$dir"
  for f in "$@"; do [[ -f $f ]] && head -c 65536 "$f" > "$dir/seed_$(basename "$f")"; done
  return 0
}
C="$BUILD/corpus"
if [[ $SECS == ci ]]; then
  C="$BUILD/corpus-ci"
  rm -rf "$C"
fi
seed "$C/ply" "$DATA"/real_pairs/*/*.ply
mkdir -p "$C/pcd"
printf '# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n0 0 0\n1 2 3\n' > "$C/pcd/seed_ascii.pcd"
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' > "$C/seed.off" 2> /dev/null || true
mkdir -p "$C/off_obj" && mv -f "$C/seed.off" "$C/off_obj/seed.off"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$C/off_obj/seed.obj"
seed "$C/kitti" "$DATA"/kitti/hdl64_sample/000000.bin "$DATA"/kitti/calib/00.txt "$DATA"/kitti/times/00.txt "$DATA"/kitti/poses/00.txt
seed "$C/trajectories" "$DATA"/tum/*.txt "$DATA"/rgbd_open3d/*.log "$DATA"/rgbd_open3d/*.json
seed "$C/png" $(ls "$DATA"/rgbd_open3d/depth/*.png 2> /dev/null | head -2) $(ls "$DATA"/rgbd_open3d/color/*.png 2> /dev/null | head -1)
seed "$C/jpeg" $(ls "$DATA"/rgbd_open3d/color/*.jpg 2> /dev/null | head -2)
# HDF5 files written by the project's writer and by the C API (tests/fuzz/seeds/hdf5, fixed bytes:
# HDF5 stores modification times, so freshly written files would make the CI run differ), plus
# the io tests' scratch files in timed runs.
seed "$C/hdf5" "$ROOT"/tests/fuzz/seeds/hdf5/*.h5
if [[ $SECS != ci ]]; then
  seed "$C/hdf5" $(find "$ROOT"/build*/test_scratch -name '*.h5' -size -64k 2> /dev/null | sort | head -4)
fi
seed "$C/rawlog" /usr/share/mrpt/datasets/rot_scan_2d.rawlog /usr/share/mrpt/datasets/localization_demo.rawlog
seed "$C/graph" "$DATA"/posegraph/tinyGrid3D.g2o "$DATA"/posegraph/intel.g2o
seed "$C/yaml" "$ROOT"/config/*.yaml "$ROOT"/config/obmnet/*.yaml
# Model files: the small untrained models the unit tests write (build*/test_scratch: run the
# obmnet tests first), whole (the 64 kB cut of seed() would leave only broken archives).
if [[ " $TARGETS " == *" model "* ]]; then
  mkdir -p "$C/model"
  for f in $(find "$ROOT"/build*/test_scratch -name '*.pt' -size -1000k 2> /dev/null | sort | head -6); do
    cp "$f" "$C/model/seed_$(basename "$(dirname "$f")")_$(basename "$f")"
  done
fi
# Every past finding (tests/fuzz/regressions/<target>/) is a seed too.
for t in $TARGETS; do
  mkdir -p "$C/$t"
  seed "$C/$t" "$ROOT"/tests/fuzz/regressions/"$t"/*
done

printf '\n| target | seconds | executions | exec/s | coverage (edges) | corpus | crashes |\n|---|---:|---:|---:|---:|---:|---:|\n' > "$BUILD/table.md"
status=0
for t in $TARGETS; do
  # Findings are this run's (a crash of an earlier run is either fixed and a regression seed, or
  # still found again).
  rm -rf "$BUILD/findings/$t"
  mkdir -p "$BUILD/findings/$t"
  log="$BUILD/findings/$t.log"
  # Memory limit: 2 GB, except for rawlogs. MRPT's deserializer sizes a string or vector from the
  # length stored in the file (up to 4 GiB) before reading it; the read then fails and the reader
  # reports a FormatError (e.g. "object 27: cannot deserialize"). The allocation is MRPT's, not a
  # crash, so rawlogs get room for it.
  # (Zero-filling such a string takes seconds under ASan: rawlogs get a longer per-input timeout.)
  limit=(-rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10)
  [[ $t == rawlog ]] && limit=(-rss_limit_mb=6144 -malloc_limit_mb=4608 -timeout=60)
  # Timed rawlog runs use libFuzzer's fork mode: MRPT's allocations sized from the file also come
  # as several vectors of gigabytes (out of memory) or several strings zero-filled in a row (85 s
  # for one 21 kB input beside other jobs), and each would stop a plain run within minutes. In
  # fork mode those are counted (the table's "MRPT oom/timeouts" in the log) and the run goes on;
  # a crash or a leak still stops it and is a finding.
  fork=()
  [[ $t == rawlog && $SECS != ci && $SECS != runs:* ]] && fork=(-fork=1 -ignore_ooms=1 -ignore_timeouts=1)
  # A model file is half a megabyte (inputs up to 1 MB) and LibTorch keeps its own caches.
  max_len=262144
  [[ $t == model ]] && max_len=1048576 && limit=(-rss_limit_mb=4096 -malloc_limit_mb=2048 -timeout=30)
  if [[ $SECS == ci ]]; then
    budget=(-runs=3000 -seed=1)
  elif [[ $SECS == runs:* ]]; then
    budget=(-runs="${SECS#runs:}")
  else
    budget=(-max_total_time="$SECS")
  fi
  started=$SECONDS
  set +e
  # allocator_may_return_null=1: a request beyond what can be mapped returns NULL, as glibc's
  # malloc does outside the sanitizer (HDF5 sizes metadata cache entries from the file and handles
  # the NULL); allocations that succeed above -malloc_limit_mb are still findings.
  ASAN_OPTIONS="detect_container_overflow=0:detect_odr_violation=0:detect_leaks=1:allocator_may_return_null=1" \
  LSAN_OPTIONS="suppressions=$ROOT/.ci/lsan.supp:print_suppressions=0" \
    "$(fuzzer "$t")" "${budget[@]}" "${limit[@]}" "${fork[@]}" \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$BUILD/findings/$t/" "$C/$t" > "$log" 2>&1
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  corpus=$(ls "$C/$t" | wc -l)
  # libFuzzer's own artifacts of a finding (slow-unit-* files are only reports of slow inputs).
  crashes=$(find "$BUILD/findings/$t" -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' | wc -l)
  if (( ${#fork[@]} > 0 )); then
    # Fork mode's status lines: "#N: cov: C ft: F corp: K exec/s E oom/timeout/crash: O/T/X ...".
    last=$(grep -E '^#[0-9]+: cov:' "$log" | tail -1)
    execs=$(sed -E 's/^#([0-9]+):.*/\1/' <<< "$last")
    rate=$(sed -E 's/.*exec\/s:? ([0-9]+).*/\1/' <<< "$last")
    echo "[fuzz] $t: MRPT oom/timeout/crash counts: $(sed -E 's/.*oom\/timeout\/crash: ([0-9/]+).*/\1/' <<< "$last")" >&2
    crashes=$(find "$BUILD/findings/$t" -name 'crash-*' -o -name 'leak-*' | wc -l)
  fi
  printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$t" "$((SECONDS - started))" "${execs:-?}" "${rate:-?}" "${cov:-?}" "$corpus" "$crashes" >> "$BUILD/table.md"
  (( ${#fork[@]} > 0 && crashes == 0 )) && rc=0  # fork mode exits non-zero after ignored OOMs
  if (( rc != 0 || crashes > 0 )); then
    status=1
    echo "[fuzz] $t: FINDING (exit $rc) — $log" >&2
    grep -m3 -E 'ERROR|SUMMARY|terminate|what\(\)' "$log" >&2 || true
  fi
done
cat "$BUILD/table.md"
exit $status
