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
