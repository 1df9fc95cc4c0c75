#!/usr/bin/env bash
# Shows that the tests tell every shipped model from an untrained network of the same shape: for
# each model of share/obmslam/models, a copy of the folder where that one model is replaced by
# fresh weights (build/tests/untrained_like), and the tests that read models run against it
# (OBM_TEST_MODELS), stopping at the first failure. Prints a table: the model and the first test
# that failed, and exits 1 when some model fails no test. Needs the Release build (scripts/test.sh or scripts/build.sh).
#
#   scripts/check_models_matter.sh [MODEL...]       # default: every shipped model
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${OBM_BUILD:-$ROOT/build}"
MODELS="$ROOT/share/obmslam/models"
tool="$BUILD/tests/untrained_like"
[[ -x "$tool" ]] || { echo "check_models_matter: $tool missing (scripts/build.sh)" >&2; exit 1; }
[[ -n "${OBM_CGAL_DATA:-}" ]] || OBM_CGAL_DATA="$("$ROOT/scripts/get_cgal_meshes.sh")" && export OBM_CGAL_DATA
names=("$@")
if ((${#names[@]} == 0)); then
  for f in "$MODELS"/*.pt; do names+=("$(basename "$f" .pt)"); done
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# The tests that load a shipped model by name (tests/common/test_data.hpp, modelsDir()).
pattern="ModelAccuracy|KittiObmNet|AWrongLoopOfTheNetworkMatcher"
printf '| model | tests run | failed with the untrained network in its place |\n|---|---:|---|\n'
status=0
for name in "${names[@]}"; do
  rm -rf "$work/models" && mkdir -p "$work/models"
  cp "$MODELS"/*.pt "$work/models/"
  "$tool" "$MODELS/$name.pt" "$work/models/$name.pt" 7 > /dev/null
  log="$work/$name.log"
  OBM_TEST_MODELS="$work/models" ctest --test-dir "$BUILD" -R "$pattern" -j"$(nproc)" \
    --stop-on-failure --timeout 1200 > "$log" 2>&1 || true
  run=$(grep -cE '^ *[0-9]+/[0-9]+ Test +#' "$log" || true)
  # ctest's summary: "<tab> 42 - registration.ModelAccuracy.X (Failed)" (or SEGFAULT, Timeout, ...)
  failed=$(grep -E '^\s+[0-9]+ - \S+ \(' "$log" | sed -E 's/^\s+[0-9]+ - (\S+) .*/\1/' |
    sed 's/^registration\.//; s/^frontend\.//' | paste -sd ',' - | sed 's/,/, /g' || true)
  [[ -n "$failed" ]] || { failed="**none**"; status=1; }
  printf '| %s | %s | %s |\n' "$name" "$run" "$failed"
done
exit $status
