#!/usr/bin/env bash
# End-to-end checks of `sagitta tessellate --scheme pn`: counts and crack reports from the CLI.
# Env: SAGITTA (the binary), SHARED_DATA (../shared/data). Skips (exit 0, saying so) without data.
set -euo pipefail
: "${SAGITTA:?}" "${SHARED_DATA:?}"
if [[ ! -f "$SHARED_DATA/mesh/cube.obj" || ! -f "$SHARED_DATA/mesh/spot_triangulated.obj" ]]; then
  echo "shared data absent: skipping"; exit 0
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
field() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }

"$SAGITTA" tessellate "$SHARED_DATA/mesh/spot_triangulated.obj" --scheme pn --level 3 --stats "$tmp/s.json" --out "$tmp/s.ply" >/dev/null
[[ $(field "$tmp/s.json" triangles) == 52704 ]] || fail "spot k=3 should give 5856*9 triangles"
[[ $(field "$tmp/s.json" open_edges) == 0 ]] || fail "spot k=3 should be closed"

"$SAGITTA" tessellate "$SHARED_DATA/mesh/cube.obj" --scheme pn --level 3 --normals face --stats "$tmp/c.json" >/dev/null
[[ $(field "$tmp/c.json" open_edges) == 72 ]] || fail "basic cube with face normals: 24k open edges"
[[ $(field "$tmp/c.json" crease_edges) == 12 ]] || fail "cube has 12 crease edges"
"$SAGITTA" tessellate "$SHARED_DATA/mesh/cube.obj" --scheme pn --level 3 --normals face --pn-variant aen --stats "$tmp/a.json" >/dev/null
[[ $(field "$tmp/a.json" open_edges) == 0 ]] || fail "AEN cube should be closed"

"$SAGITTA" tessellate "$SHARED_DATA/mesh/cube.obj" --scheme pn --pattern fractional_odd --tess-factor 2.5 --stats "$tmp/f.json" >/dev/null
[[ $(field "$tmp/f.json" triangles) == $((12 * 13)) ]] || fail "fractional_odd 2.5: 13 triangles per input triangle"

if [[ -f "$SHARED_DATA/teapot.bpt" ]]; then
  "$SAGITTA" tessellate "$SHARED_DATA/teapot.bpt" --scheme pn --base-level 1 --level 2 --stats "$tmp/t.json" >/dev/null
  [[ $(field "$tmp/t.json" triangles) == 960 ]] || fail "teapot base level 1 (240 triangles) at k=2: 960"
fi

# Errors are one line on stderr with a non-zero exit.
if "$SAGITTA" tessellate "$SHARED_DATA/mesh/cube.obj" --scheme uniform --level 2 2>"$tmp/err"; then fail "uniform on a mesh must fail"; fi
grep -q "only be refined with --scheme pn" "$tmp/err" || fail "unclear error: $(cat "$tmp/err")"
if "$SAGITTA" tessellate "$SHARED_DATA/mesh/cube.obj" --scheme pn --tess-factor 2.5 2>"$tmp/err"; then fail "--tess-factor needs fractional_odd"; fi
echo "pn CLI checks passed"
