#!/usr/bin/env bash
# Fetches CGAL's sample meshes (OFF/PLY) from the Debian package libcgal-demo, without installing
# it: `apt-get download` the .deb, `dpkg -x` it, and unpack its data.tar.gz. Nothing else is
# downloaded. Idempotent: a second run only prints the folder.
#
#   scripts/get_cgal_meshes.sh            # prints the folder holding the .off meshes
#   export OBM_CGAL_DATA=$(scripts/get_cgal_meshes.sh)
#
# Cache folder: ${OBM_CACHE:-$HOME/.cache/obmslam}/cgal
set -euo pipefail

cache="${OBM_CACHE:-$HOME/.cache/obmslam}/cgal"
meshes="$cache/data/meshes"

if [[ -f "$meshes/elephant.off" ]]; then
  echo "$meshes"
  exit 0
fi

mkdir -p "$cache"
cd "$cache"
if ! ls libcgal-demo_*.deb >/dev/null 2>&1; then
  echo "[get_cgal_meshes] apt-get download libcgal-demo into $cache" >&2
  if ! apt-get download libcgal-demo >&2; then
    echo "[get_cgal_meshes] download failed; the package lists may be missing: run 'apt-get update'" >&2
    exit 1
  fi
fi
deb=$(ls libcgal-demo_*.deb | head -n 1)
rm -rf pkg
dpkg -x "$deb" pkg
tarball=$(find pkg -name data.tar.gz | head -n 1)
if [[ -z "$tarball" ]]; then
  echo "[get_cgal_meshes] no data.tar.gz in $deb" >&2
  exit 1
fi
tar xzf "$tarball" -C "$cache"
rm -rf pkg
if [[ ! -d "$meshes" ]]; then
  # A later package layout: report wherever the .off files are.
  first=$(find "$cache" -name '*.off' | head -n 1)
  if [[ -z "$first" ]]; then
    echo "[get_cgal_meshes] no .off meshes found under $cache" >&2
    exit 1
  fi
  meshes=$(dirname "$first")
fi
echo "$meshes"
