#!/usr/bin/env bash
# End-to-end checks of issue 20 item 9: `sagitta tessellate --scheme esc` next to a side collapsed
# to a point emits no triangle twice; `sagitta validate` names duplicated faces and inside-out
# (mirrored) closed components in its text line and its JSON. Argument: this folder.
set -u
here=$1
fail=0; passed=0
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
check() { if eval "$2"; then passed=$((passed+1)); else echo "FAIL: $1"; fail=$((fail+1)); fi; }
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }
# Number of faces of an OBJ file whose vertex set repeats an earlier face's.
obj_duplicates() { python3 -c "
import sys
seen, dup = set(), 0
for line in open(sys.argv[1]):
    s = line.split()
    if s and s[0] == 'f':
        key = tuple(sorted(int(x.split('/')[0]) for x in s[1:]))
        dup += key in seen
        seen.add(key)
print(dup)" "$1"; }

# A random bicubic patch whose v = 0 side is one point: ESC used to emit a triangle twice.
bpt=$here/esc_collapsed_v0.bpt
check "esc next to a collapsed v = 0 side: no face twice" "$SAGITTA tessellate $bpt --scheme esc --level 3 --threshold 0.2 --out $tmp/m.obj >/dev/null && [ \$(obj_duplicates $tmp/m.obj) = 0 ]"
check "esc next to a collapsed side: validate finds no duplicate, no non-manifold edge" "$SAGITTA validate $bpt --scheme esc --level 3 --threshold 0.2 --json $tmp/v.json >/dev/null && [ \$(json $tmp/v.json 'd[\"topology\"][\"duplicated_faces\"] == 0 and d[\"topology\"][\"non_manifold_edges\"] == 0') = True ]"

# A planted duplicate face: named in the text line and the JSON.
$SAGITTA tessellate $bpt --scheme uniform --level 2 --out $tmp/u.obj >/dev/null
grep '^f ' $tmp/u.obj | tail -1 >> $tmp/u.obj
check "validate --mesh names a duplicated face" "$SAGITTA validate $bpt --mesh $tmp/u.obj --json $tmp/d.json >$tmp/d.txt && grep -q 'duplicated faces 1' $tmp/d.txt && [ \$(json $tmp/d.json 'd[\"topology\"][\"duplicated_faces\"]') = 1 ]"

# The cube [-1, 1]^3 as 6 bilinear patches (outward), its mirror image x -> -x (patch order kept),
# and both side by side (the mirrored one moved to x + 10).
python3 - "$tmp" <<'PY'
import sys
faces = [(0, 1, 1, 2), (0, 0, 2, 1), (1, 1, 2, 0), (1, 0, 0, 2), (2, 1, 0, 1), (2, 0, 1, 0)]
def cube(sx, dx):
    out = []
    for fixed, value, ua, va in faces:
        pts = []
        for a in (0, 1):
            for b in (0, 1):
                c = [0.0, 0.0, 0.0]
                c[fixed], c[ua], c[va] = 2 * value - 1, 2 * a - 1, 2 * b - 1
                pts.append((sx * c[0] + dx, c[1], c[2]))
        out.append(pts)
    return out
def write(name, patches):
    with open(sys.argv[1] + "/" + name, "w") as f:
        f.write("%d\n" % len(patches))
        for pts in patches:
            f.write("1 1\n" + "".join("%g %g %g\n" % p for p in pts))
write("cube.bpt", cube(1, 0))
write("mirror.bpt", cube(-1, 0))
write("both.bpt", cube(1, 0) + cube(-1, 10))
PY
check "cube: one closed component, volume 8, not inside-out" "$SAGITTA validate $tmp/cube.bpt --segments 2 --json $tmp/c.json >$tmp/c.txt && grep -q 'inside-out 0' $tmp/c.txt && [ \$(json $tmp/c.json 'd[\"topology\"][\"closed_components\"] == 1 and d[\"topology\"][\"inside_out_components\"] == 0 and abs(d[\"topology\"][\"component_list\"][0][\"signed_volume\"] - 8) < 1e-9') = True ]"
check "mirrored cube: volume -8, flagged inside-out" "$SAGITTA validate $tmp/mirror.bpt --segments 2 --json $tmp/m.json >$tmp/m.txt && grep -q 'inside-out 1' $tmp/m.txt && [ \$(json $tmp/m.json 'd[\"topology\"][\"inside_out_components\"] == 1 and d[\"topology\"][\"component_list\"][0][\"inside_out\"] and abs(d[\"topology\"][\"component_list\"][0][\"signed_volume\"] + 8) < 1e-9 and any(f[\"kind\"] == \"inside_out_component\" for f in d[\"topology\"][\"findings\"])') = True ]"
check "two cubes, one mirrored: reported separately" "$SAGITTA validate $tmp/both.bpt --segments 2 --json $tmp/b.json >/dev/null && [ \$(json $tmp/b.json '[(c[\"patch\"], round(c[\"signed_volume\"], 9), c[\"inside_out\"]) for c in d[\"topology\"][\"component_list\"]] == [(0, 8.0, False), (6, -8.0, True)]') = True ]"

echo "$passed passed, $fail failed"
[ $fail = 0 ]
