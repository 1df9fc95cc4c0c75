# Shared set-up of the obm-map benchmark scripts (scripts/bench_slam.sh, scripts/slam_suite.sh);
# sourced, not run. After the script has parsed its options into BUILD, ONLY and POS (the two
# positional arguments DATA_DIR OUT_DIR):
#   bench_setup NAME   creates both folders and sets DATA, OUT (absolute), MAP and SIM (the
#                      obm-map / obm-sim binaries of BUILD; exits when they are not built)
#   want KEY           true when KEY is in the comma-separated ONLY

bench_setup() {
  local name=$1
  [[ ${#POS[@]} -eq 2 ]] || { usage >&2; exit 2; }
  mkdir -p "${POS[0]}" "${POS[1]}"
  DATA=$(cd "${POS[0]}" && pwd)
  OUT=$(cd "${POS[1]}" && pwd)
  MAP=$BUILD/bin/obm-map
  SIM=$BUILD/bin/obm-sim
  [[ -x $MAP && -x $SIM ]] || { echo "$name: $MAP / $SIM not built" >&2; exit 1; }
}

want() { [[ ",$ONLY," == *",$1,"* ]]; }
