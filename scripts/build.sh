#!/usr/bin/env bash
# Configure + build (incremental). Usage: scripts/build.sh [BUILD_DIR] [extra cmake args...]
# Environment: OBM_JOBS (parallel jobs, default: number of cores).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
shift || true
JOBS="${OBM_JOBS:-$(nproc)}"
source "$ROOT/scripts/ccache_env.sh"
GEN=()
command -v ninja >/dev/null && GEN=(-G Ninja)
if [[ ! -f "$BUILD/CMakeCache.txt" ]]; then
  cmake -S "$ROOT" -B "$BUILD" "${GEN[@]}" -DCMAKE_BUILD_TYPE=Release "$@"
elif (($#)); then
  cmake -S "$ROOT" -B "$BUILD" "$@"
fi
cmake --build "$BUILD" -j"$JOBS"
