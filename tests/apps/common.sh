# Helpers of the command-line checks (sourced).
fail() { echo "FAIL: $*" >&2; exit 1; }
# num KEY FILE: the number stored under "KEY" in a JSON file (fails when missing or null).
num() {
  local v
  v=$(grep -o "\"$1\": *[-0-9.eE+]*" "$2" | head -1 | sed 's/.*: *//')
  [[ -n "$v" ]] || fail "$2: no number under \"$1\""
  echo "$v"
}
# lt A B: A < B as floating-point numbers.
lt() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a + 0 < b + 0) }'; }
# cgal_meshes_or_skip: sets $meshes to the CGAL mesh folder (OBM_CGAL_DATA or
# scripts/get_cgal_meshes.sh's cache); without meshes, skips (exit 77), or fails in CI.
cgal_meshes_or_skip() {
  meshes="${OBM_CGAL_DATA:-${OBM_CACHE:-$HOME/.cache/obmslam}/cgal/data/meshes}"
  if ! ls "$meshes"/*.off >/dev/null 2>&1; then
    [[ "${CI:-}" == "true" ]] && fail "no CGAL meshes in $meshes (scripts/get_cgal_meshes.sh)"
    echo "SKIP: no CGAL meshes in $meshes (scripts/get_cgal_meshes.sh)"
    exit 77
  fi
}
