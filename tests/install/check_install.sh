#!/usr/bin/env bash
# Installs the build tree into a scratch prefix, then configures, builds and runs a consumer project
# that uses find_package(obmslam).
set -euo pipefail
BUILD="$1"; SRC="$2"
PREFIX="$BUILD/test_scratch/install_prefix"
CBUILD="$BUILD/test_scratch/consumer_build"
rm -rf "$PREFIX" "$CBUILD"
cmake --install "$BUILD" --prefix "$PREFIX" > /dev/null
cmake -S "$SRC/tests/install/consumer" -B "$CBUILD" -DCMAKE_PREFIX_PATH="$PREFIX" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$CBUILD" > /dev/null
"$CBUILD/consumer"
