#!/usr/bin/env bash
# The obm-graph command line exactly as documented (and as the acceptance checks call it):
#   check_obm_graph_cli.sh <obm-graph binary> <scratch folder>
set -euo pipefail
tool="$1"
work="$2"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
rm -rf "$work"
mkdir -p "$work"
cd "$work"

"$tool" --help >/dev/null || fail "--help"

# A square driven four times by the same edge (1 m forward, 90° left): consistent measurements, so
# the optimum has χ² = 0; the vertices start off by decimetres and degrees.
info="100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400"
{
  echo "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1"
  echo "VERTEX_SE3:QUAT 1 1.1 0.05 0 0 0 0.75 0.66"
  echo "VERTEX_SE3:QUAT 2 1.0 1.2 0.1 0 0 1 0"
  echo "VERTEX_SE3:QUAT 3 -0.1 0.9 0 0 0 0.68 -0.73"
  for e in "0 1" "1 2" "2 3" "3 0"; do
    echo "EDGE_SE3:QUAT $e 1 0 0 0 0 0.7071068 0.7071068 $info"
  done
} > square.g2o

"$tool" -i square.g2o -o out.g2o --report report.json > log.txt 2>&1 || { cat log.txt; fail "obm-graph failed"; }
[[ -s out.g2o ]] || fail "no output graph"
[[ $(grep -c '^VERTEX_SE3:QUAT' out.g2o) -eq 4 ]] || fail "out.g2o must keep the 4 vertices"
[[ $(grep -c '^EDGE_SE3:QUAT' out.g2o) -eq 4 ]] || fail "out.g2o must keep the 4 edges"
for k in initial_chi2 final_chi2 iterations time_s; do num "$k" report.json >/dev/null; done
grep -q '"converged": *true' report.json || fail "report: not converged"
initial=$(num initial_chi2 report.json)
final=$(num final_chi2 report.json)
lt "$final" 1e-6 || fail "final χ² $final, expected ~0 for consistent edges"
lt 1 "$initial" || fail "initial χ² $initial, expected the perturbed start's (> 1)"
# The written graph is a valid input again (round trip through the tool).
"$tool" -i out.g2o -o out2.g2o --report report2.json > /dev/null 2>&1 || fail "re-reading out.g2o"
lt "$(num initial_chi2 report2.json)" 1e-6 || fail "out.g2o does not hold the optimised poses"

# Bad input: the line is named, exit code 1, nothing written.
sed 's/^EDGE_SE3:QUAT 1 2 1 0 0/EDGE_SE3:QUAT 1 2 1 x 0/' square.g2o > bad.g2o
if "$tool" -i bad.g2o -o bad_out.g2o --report bad.json 2> bad.err; then fail "malformed line accepted"; fi
grep -q 'bad.g2o:6' bad.err || fail "malformed line not named: $(cat bad.err)"
[[ ! -e bad_out.g2o && ! -e bad.json ]] || fail "a failed run wrote output"
grep -v '^VERTEX_SE3:QUAT 2 ' square.g2o > missing.g2o
if "$tool" -i missing.g2o -o bad_out.g2o 2> missing.err; then fail "edge to a missing vertex accepted"; fi
[[ ! -e bad_out.g2o ]] || fail "a failed run wrote output"
echo "obm-graph command line: OK"
