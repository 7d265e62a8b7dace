#!/usr/bin/env bash
# `sagitta scene` end to end: a scene of built-in fixtures (no shared data needed), its JSON report,
# the mesh output, and one-line errors with exit status 2 for bad scenes. Needs SAGITTA.
set -u
fail=0
check() { if ! eval "$2"; then echo "FAILED: $1"; fail=1; fi; }
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

cat > "$dir/boxes.json" <<'JSON'
{
 "models": {"box": "fixture:pillow_box", "torus": "fixture:rational_torus"},
 "instances": [
  {"model": "box", "translate": [0, 0, 0]},
  {"model": "box", "translate": [4, 0, 0], "scale": [1, 2, 1]},
  {"model": "torus", "translate": [-6, 0, 0], "rotate": {"axis": [1, 0, 0], "degrees": 90}},
  {"model": "box", "translate": [0, 0, 100]}
 ],
 "camera": {"eye": [0, -12, 3], "target": [0, 0, 0], "up": [0, 0, 1], "fov_y_degrees": 60, "width": 800, "height": 600},
 "tolerance_pixels": 1.5
}
JSON
before=$(sha256sum "$dir/boxes.json")
"$SAGITTA" scene "$dir/boxes.json" --json "$dir/out.json" --out "$dir/out.ply" > "$dir/stdout" 2> "$dir/stderr"
check "fixture scene runs" "[ $? -eq 0 ]"
check "input unchanged" "[ \"$(sha256sum "$dir/boxes.json")\" = \"$before\" ]"
check "mesh written" "[ -s \"$dir/out.ply\" ]"
check "report has counts per model" "grep -q '\"name\": \"torus\"' \"$dir/out.json\" && grep -q '\"level_histogram\"' \"$dir/out.json\""
# The box 100 units above the target is outside the view: its 6 patches are culled.
check "culled box" "python3 -c \"import json,sys; d=json.load(open('$dir/out.json')); sys.exit(0 if d['culled']['outside_view'] + d['culled']['back_facing'] >= 6 and d['over_tolerance'] == 0 and d['triangles'] > 0 else 1)\""

# Bad scenes: exit status 2 and one line "sagitta: FILE: JSON.PATH: problem".
printf '{"models": {"a": "fixture:pillow_box"}, "instances": [{"model": "b"}], "camera": {}, "tolerance_pixels": 1}' > "$dir/bad.json"
"$SAGITTA" scene "$dir/bad.json" 2> "$dir/err"; status=$?
check "unknown model exits 2" "[ $status -eq 2 ]"
check "unknown model message" "grep -qx 'sagitta: $dir/bad.json: instances\[0\].model: unknown model \"b\"' \"$dir/err\""
printf '{"models": {"cup": "data:teacup.bpt"}, "instances": [{"model": "cup"}], "camera": {"eye": [0,-5,0], "target": [0,0,0], "up": [0,0,1], "fov_y_degrees": 45, "width": 10, "height": 10}, "tolerance_pixels": 1}' > "$dir/data.json"
env -u SAGITTA_DATA_DIR "$SAGITTA" scene "$dir/data.json" 2> "$dir/err"; status=$?
check "data: without a folder exits 2" "[ $status -eq 2 ] && grep -q 'needs the shared data folder' \"$dir/err\""
"$SAGITTA" scene "$dir/boxes.json" --json "$dir/boxes.json" 2> "$dir/err"; status=$?
check "refuses to overwrite the scene" "[ $status -eq 2 ] && grep -q 'refusing to overwrite' \"$dir/err\""
check "scene still intact" "[ \"$(sha256sum "$dir/boxes.json")\" = \"$before\" ]"
exit $fail
