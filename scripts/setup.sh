#!/usr/bin/env bash
# Installs what obmslam needs from Debian 12 packages, and nothing else. Idempotent: packages that are
# already installed are not touched; `apt-get update` runs only when the package lists are missing or
# an install fails for want of them. Needs root or sudo.
#
#   scripts/setup.sh            # install missing build + runtime packages
#   scripts/setup.sh --check    # only report what is missing (exit 1 if anything is)
set -euo pipefail

PACKAGES=(
  # toolchain (clang: the libFuzzer targets of scripts/fuzz.sh; lld: the linker, see CMakeLists.txt)
  cmake g++ clang libclang-rt-14-dev lld ninja-build ccache pkg-config git
  # libraries
  libeigen3-dev libmrpt-dev libtorch-dev libceres-dev liboctomap-dev libgtest-dev libgmock-dev
  libembree-dev libhdf5-dev libnanoflann-dev libyaml-cpp-dev nlohmann-json3-dev libpng-dev libjpeg-dev libcli11-dev
  zlib1g-dev  # model files: their deflated entries are checked before LibTorch reads them
  libgloo-dev  # headers of LibTorch's c10d Gloo process group (data-parallel obm-train)
  libtcmalloc-minimal4  # allocator of the applications (LibTorch's large temporaries)
  # BLAS behind LibTorch: Debian's default alternative is ATLAS; OpenBLAS threaded with OpenMP shares
  # LibTorch's thread pool and halves OBMNet's inference time (151.7 -> 84.7 ms per 1024-point pair)
  libopenblas0-openmp
  libopen3d-dev
  # MRPT tools and datasets (graph-slam, icp-slam peers; /usr/share/mrpt/datasets/*.rawlog test data)
  mrpt-apps mrpt-common
  # headless browser of the report.html check (tests/apps/check_report_html.sh)
  chromium fonts-dejavu-core
  # CGAL's sample meshes and point sets, read by the tests on real meshes (scripts/get_cgal_meshes.sh)
  libcgal-demo
  # the demo prints obm-map's metrics with python3; scripts/bench_slam.sh scores with it;
  # tests/apps/check_obm_bench_cli.sh reads obm-bench's per-pair CSV with it
  python3
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ "${1:-}" == "--check" ]]; then
  if ((${#missing[@]})); then echo "missing packages: ${missing[*]}"; exit 1; fi
  echo "all packages installed"; exit 0
fi

if ((${#missing[@]} == 0)); then
  echo "[setup] all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null; then SUDO="sudo"; else
    echo "[setup] error: need root or sudo to install: ${missing[*]}" >&2; exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
echo "[setup] installing: ${missing[*]}"
if [[ -z "$(ls -A /var/lib/apt/lists 2>/dev/null | grep -v -e lock -e partial || true)" ]]; then
  $SUDO apt-get update -qq
fi
if ! $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"; then
  echo "[setup] install failed; refreshing package lists and retrying"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
echo "[setup] done"
