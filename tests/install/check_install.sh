#!/usr/bin/env bash
# Installs the build tree into a scratch prefix, then configures, builds and runs a consumer project
# that uses find_package(obmslam).
set -euo pipefail
BUILD="$1"; SRC="$2"
PREFIX="$BUILD/test_scratch/install_prefix"
CBUILD="$BUILD/test_scratch/consumer_build"
rm -rf "$PREFIX" "$CBUILD"
cmake --install "$BUILD" --prefix "$PREFIX" > /dev/null
# Every installed preset and obm-map config names a model that exists where it is installed
# (paths relative to the config, as in the source tree).
for cfg in "$PREFIX"/share/obmslam/config/presets/*.yaml "$PREFIX"/share/obmslam/config/map_*.yaml; do
  model=$(sed -n 's/^ *model_path: *\([^ #]*\).*/\1/p' "$cfg" | head -1)
  [[ -z "$model" ]] && continue
  [[ -f "$(dirname "$cfg")/$model" ]] || { echo "FAIL: $cfg: model $model not installed there" >&2; exit 1; }
done
cmake -S "$SRC/tests/install/consumer" -B "$CBUILD" -DCMAKE_PREFIX_PATH="$PREFIX" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$CBUILD" > /dev/null
"$CBUILD/consumer"
