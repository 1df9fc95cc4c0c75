#!/usr/bin/env bash
# obm-map's page and picture of a run (docs/obm-map.md, "Outputs"), opened in headless Chromium:
#   check_report_html.sh <bin dir> <source root> <scratch folder>
# The SVG top view must be well-formed and carry the estimate, the ground truth, a scale bar, a
# legend and the metrics in its title; report.html, loaded by Chromium, must hold the picture, the
# error-over-distance plot and the tables, and render to a non-blank screenshot.
# Needs chromium (scripts/setup.sh installs it): skipped (exit 77) without it, except in CI.
set -euo pipefail
bin="$1"
root="$2"
work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
browser=$(command -v chromium || command -v chromium-browser || true)
if [[ -z $browser ]]; then
  [[ "${CI:-}" == "true" ]] && fail "chromium not installed (scripts/setup.sh)"
  echo "SKIP: chromium not installed"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work"
cd "$root"
seq="$work/seq"
"$bin/obm-sim" --preset kitti_like_urban --frames 60 --seed 7 --out "$seq" --quiet --log-level warn
out="$work/out"
"$bin/obm-map" --config config/map_kitti.yaml --input "$seq" --out "$out" --matcher icp -q \
  > "$work/map.log" 2>&1 || { tail -20 "$work/map.log"; fail "obm-map"; }
for f in report.html trajectory_topview.svg; do [[ -s $out/$f ]] || fail "obm-map: missing $f"; done

# The SVG: well-formed XML with every part of the picture.
python3 - "$out/trajectory_topview.svg" <<'PY' || fail "trajectory_topview.svg"
import sys, xml.etree.ElementTree as ET
root = ET.parse(sys.argv[1]).getroot()
ns = "{http://www.w3.org/2000/svg}"
classes = {e.get("class") for e in root.iter() if e.get("class")}
need = {"estimate", "reference", "scalebar", "legend", "metrics"}
missing = need - classes
assert not missing, f"missing parts: {missing}"
texts = " ".join(t.text or "" for t in root.iter(ns + "text"))
assert "ATE 0." in texts, f"no ATE in the title: {texts[:200]}"
assert "x [m]" in texts and "y [m]" in texts, "axes not labelled in metres"
est = next(e for e in root.iter(ns + "polyline") if e.get("class") == "estimate")
assert len(est.get("points").split()) == 60, "one estimate vertex per frame"
PY

# The page in the browser: the DOM Chromium builds from it, then a screenshot.
timeout 120 "$browser" --headless=new --no-sandbox --disable-gpu --dump-dom "file://$out/report.html" \
  > "$work/dom.html" 2> "$work/chromium.log" || { tail "$work/chromium.log"; fail "chromium --dump-dom"; }
for id in "id=\"trajectory\"" "id=\"error\"" "id=\"metrics\"" "id=\"frames\"" "id=\"timing\"" \
          "trajectory_topview.png"; do
  grep -q "$id" "$work/dom.html" || fail "report.html as loaded by Chromium lacks $id"
done
timeout 120 "$browser" --headless=new --no-sandbox --disable-gpu --hide-scrollbars \
  --window-size=1600,1400 --screenshot="$work/shot.png" "file://$out/report.html" \
  > /dev/null 2>> "$work/chromium.log" || { tail "$work/chromium.log"; fail "chromium --screenshot"; }
# Non-blank: a white page compresses to a few kB; the plots and tables make it far larger.
size=$(stat -c %s "$work/shot.png")
(( size > 40000 )) || fail "the screenshot is nearly empty ($size bytes)"
echo "report.html in headless Chromium: OK (screenshot $size bytes)"
