#!/usr/bin/env bash
# Unpacks CGAL's sample meshes (OFF/PLY) from the Debian package libcgal-demo: from the installed
# package's data.tar.gz (scripts/setup.sh installs it), else from the .deb fetched with
# `apt-get download` and unpacked with `dpkg -x`. Idempotent: a second run only prints the folder.
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
# The package installed (scripts/setup.sh installs it): its data tarball, no download.
tarball=/usr/share/doc/libcgal-dev/data.tar.gz
if [[ ! -f "$tarball" ]]; then
  if ! ls libcgal-demo_*.deb >/dev/null 2>&1; then
    echo "[get_cgal_meshes] apt-get download libcgal-demo into $cache" >&2
    if ! apt-get download libcgal-demo >&2; then
      echo "[get_cgal_meshes] download failed; refreshing the package lists and retrying" >&2
      sudo=""; [[ $(id -u) -ne 0 ]] && command -v sudo >/dev/null && sudo=sudo
      $sudo apt-get update -qq >&2 || true
      apt-get download libcgal-demo >&2 ||
        { echo "[get_cgal_meshes] cannot download libcgal-demo" >&2; exit 1; }
    fi
  fi
  deb=$(ls libcgal-demo_*.deb | head -n 1)
  rm -rf pkg
  dpkg -x "$deb" pkg
  tarball=$(find "$cache/pkg" -name data.tar.gz | head -n 1)
  if [[ -z "$tarball" ]]; then
    echo "[get_cgal_meshes] no data.tar.gz in $deb" >&2
    exit 1
  fi
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
