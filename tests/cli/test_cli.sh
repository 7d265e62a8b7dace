#!/usr/bin/env bash
# End-to-end checks of the sagitta command: the issue's acceptance commands and error messages.
set -u
fail=0; passed=0
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
check() { if eval "$2"; then passed=$((passed+1)); else echo "FAIL: $1"; fail=$((fail+1)); fi; }
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

# Main job on the built-in default model.
check "run on the default model" "$SAGITTA run --out-dir $tmp/run >$tmp/run.log 2>&1 && test -s $tmp/run/uniform.ply && test -s $tmp/run/report.json"
check "run writes every scheme, the fit and the report" "test -s $tmp/run/esc.ply && test -s $tmp/run/pn.ply && test -s $tmp/run/fit.ply && grep -q 'data:image/png;base64' $tmp/run/report.html && [ \$(json $tmp/run/fit.json 'd[\"met\"] and d[\"certified_error\"] <= d[\"target_error\"]') = True ]"
check "fit refuses a bad target" "! $SAGITTA fit --scheme esc --target-error -1 2>$tmp/err && grep -q 'target-error must be a positive' $tmp/err && [ \$(wc -l < $tmp/err) = 1 ]"

if [ -f "$SHARED_DATA/teapot.bpt" ]; then
  check "teapot level 3" "$SAGITTA tessellate $SHARED_DATA/teapot.bpt --scheme uniform --level 3 --out $tmp/t.obj --stats $tmp/t.json >/dev/null"
  check "teapot triangles + degenerate = 4096" "[ \$(json $tmp/t.json 'd[\"triangles\"]+d[\"degenerate_triangles\"]') = 4096 ]"
  check "stats keys" "[ \$(json $tmp/t.json 'all(k in d for k in [\"scheme\",\"patches\",\"vertices\",\"triangles\",\"degenerate_triangles\",\"seconds\"])') = True ]"
  check "obj written" "grep -c '^f ' $tmp/t.obj | grep -qx 4032"
  check "100 teacups copies" "$SAGITTA tessellate $SHARED_DATA/teacup.bpt --copies 100 --segments 15 --stats $tmp/c.json >/dev/null && [ \$(json $tmp/c.json 'd[\"patches\"]') = 2600 ]"
  check "esc per-edge levels: fewer triangles than the paper's test, still certified and crack-free" "$SAGITTA validate $SHARED_DATA/teacup.bpt --scheme esc --level 3 --threshold 0.011941 --json $tmp/ep.json >/dev/null && $SAGITTA validate $SHARED_DATA/teacup.bpt --scheme esc --level 3 --threshold 0.011941 --per-edge-levels --json $tmp/ee.json >/dev/null && [ \$(python3 -c \"import json; a=json.load(open('$tmp/ep.json')); b=json.load(open('$tmp/ee.json')); print(b['triangles'] < a['triangles'] and b['tessellation']['per_edge_levels'] and b['topology']['crack_edges'] == 0 and b['hausdorff']['upper'] / b['hausdorff']['lower'] <= 1.1)\") = True ]"
  # --certify: the same interval as `sagitta validate` on the same mesh (the certificate is a pure
  # function of the model and the mesh), for the grid scheme and ESC; pn too (its triangles carry the
  # base grid's (patch, u, v)).
  for s in "uniform --level 3" "esc --level 3 --threshold 0.011941"; do
    check "tessellate --certify ($s) = validate" "$SAGITTA tessellate $SHARED_DATA/teacup.bpt --scheme $s --certify --stats $tmp/tc.json >$tmp/tc.log && $SAGITTA validate $SHARED_DATA/teacup.bpt --scheme $s --json $tmp/vc.json >/dev/null && grep -q '^certified: hausdorff in' $tmp/tc.log && [ \$(python3 -c \"import json; a=json.load(open('$tmp/tc.json'))['certificate']; b=json.load(open('$tmp/vc.json')); print(a['certified'] and a['method'] == 'bernstein' and a['hausdorff']['lower'] == b['hausdorff']['lower'] and a['hausdorff']['upper'] == b['hausdorff']['upper'] and 0 < a['hausdorff']['lower'] <= a['hausdorff']['upper'])\") = True ]"
  done
  check "tessellate --certify, pn" "$SAGITTA tessellate $SHARED_DATA/teaspoon.bpt --scheme pn --base-level 2 --level 2 --certify --stats $tmp/tp.json >/dev/null && [ \$(json $tmp/tp.json 'd[\"certificate\"][\"certified\"] and 0 < d[\"certificate\"][\"hausdorff\"][\"lower\"] <= d[\"certificate\"][\"hausdorff\"][\"upper\"]') = True ]"
  check "tessellate without --certify has no certificate" "[ \$(json $tmp/t.json '\"certificate\" in d') = False ]"
  cp "$SHARED_DATA/teapot.bpt" "$tmp/in.bpt"
  check "refuses to overwrite its input" "! $SAGITTA tessellate $tmp/in.bpt --level 1 --out $tmp/in.bpt 2>$tmp/err && grep -q 'refusing to overwrite the input' $tmp/err && cmp -s $tmp/in.bpt $SHARED_DATA/teapot.bpt"
else
  echo "SKIP: shared data absent ($SHARED_DATA)"
fi

# Bad input: one line naming the file and the problem, exit code 2.
printf '1\n3 3\n0 0 0\n' > "$tmp/trunc.bpt"
$SAGITTA tessellate "$tmp/trunc.bpt" --level 1 2>"$tmp/err"; rc=$?
check "truncated file exit code" "[ $rc = 2 ]"
check "truncated file message" "grep -q \"trunc.bpt:3: file ends early: expected control point 1 of patch 0 of 1\" $tmp/err && [ \$(wc -l < $tmp/err) = 1 ]"
check "missing file" "! $SAGITTA tessellate $tmp/nope.bpt --level 1 2>$tmp/err && grep -q 'nope.bpt: no such file' $tmp/err"
check "level too large" "! $SAGITTA tessellate --level 13 2>$tmp/err && grep -q 'outside 0..12' $tmp/err"
check "max triangles" "! $SAGITTA tessellate --level 9 --max-triangles 1000 2>$tmp/err && grep -q 'more than --max-triangles 1000' $tmp/err"
check "level and segments exclusive" "! $SAGITTA tessellate --level 2 --segments 3 2>$tmp/err && grep -q 'exactly one of' $tmp/err"
check "help explains options" "$SAGITTA tessellate --help | grep -q -- '--copies'"
check "unknown output type" "! $SAGITTA tessellate --level 1 --out $tmp/x.xyz 2>$tmp/err && grep -q 'unknown mesh type' $tmp/err"

echo "cli: $passed passed, $fail failed"
[ "$fail" = 0 ]
