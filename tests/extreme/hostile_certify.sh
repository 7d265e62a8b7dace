#!/usr/bin/env bash
# False certificates and crashes at hostile magnitudes through the sagitta command (issue 20, items
# 1-4): weights of 1e-200 or 1e308 and coordinates of 1e-300 or 1e110 give the interval of the
# well-scaled patch (scaled) or "not certified", never an upper bound below the lower one; a patch
# collapsed to a line or a point neither crashes nor gives lower > upper; coordinates beyond 1e150
# are refused with one line and exit 2, never a file of NaNs or a SIGFPE/SIGSEGV.
set -u
fail=0; passed=0
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
check() { if eval "$2"; then passed=$((passed+1)); else echo "FAIL: $1"; sed 's/^/  stderr: /' "$tmp/err" 2>/dev/null; fail=$((fail+1)); fi; }
# json FILE EXPR: a value from a JSON file (python3 is a dependency of the project).
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"; }
bilinear() {  # $1 coordinate scale, $2 weight
  python3 -c "s=float('$1'); w='$2'; print('1\n1 1'); [print(f'{x*s!r} {y*s!r} {z*s!r} {w}') for x,y,z in [(0,0,0),(0,1,0),(1,0,0),(1,1,1)]]"
}
bilinear 1 1 > "$tmp/w1.bpt"
bilinear 1 1e-200 > "$tmp/w200.bpt"
bilinear 1 1e-160 > "$tmp/w160.bpt"
bilinear 1 1e308 > "$tmp/w308.bpt"
bilinear 1e-300 1 > "$tmp/tiny.bpt"
bilinear 1e110 1 > "$tmp/big110.bpt"
printf '1\n1 1\n0 0 0\n0 1e200 0\n1e200 0 0\n1e200 1e200 1e200\n' > "$tmp/big200.bpt"
printf '1\n1 1\n0 0 0\n0 1e308 0\n1e308 0 0\n1e308 1e308 1e308\n' > "$tmp/big308.bpt"
printf '1\n1 1\n0 0 0\n0 0 0\n1 1 1\n1 1 1\n' > "$tmp/line.bpt"
printf '1\n1 1\n1 2 3\n1 2 3\n1 2 3\n1 2 3\n' > "$tmp/point.bpt"
# A bicubic with weights 1e-300 is the same surface as with weights 1.
python3 -c "
import random; random.seed(3)
print('1\n3 3')
for i in range(4):
  for j in range(4): print(i/3, j/3, 0.3*random.random(), '1e-300')" > "$tmp/cubic300.bpt"
sed 's/ 1e-300$/ 1/' "$tmp/cubic300.bpt" > "$tmp/cubic1.bpt"

# 1. The same interval for weights 1, 1e-200, 1e-160, 1e308, and scaled for coordinates.
$SAGITTA validate "$tmp/w1.bpt" --level 0 --json "$tmp/w1.json" >/dev/null 2>"$tmp/err"
for case in w200 w160 w308; do
  $SAGITTA validate "$tmp/$case.bpt" --level 0 --max-error 0.1 --json "$tmp/$case.json" >/dev/null 2>"$tmp/err"; rc=$?
  check "$case: --max-error 0.1 fails like weights 1 (exit 3, got $rc)" "[ $rc = 3 ]"
  check "$case: same certified interval as weights 1" \
    "[ \"\$(json $tmp/$case.json '\"%.9g %.9g %s\" % (d[\"hausdorff\"][\"lower\"], d[\"hausdorff\"][\"upper\"], d[\"certified\"])')\" = \"\$(json $tmp/w1.json '\"%.9g %.9g %s\" % (d[\"hausdorff\"][\"lower\"], d[\"hausdorff\"][\"upper\"], d[\"certified\"])')\" ]"
done
for case in tiny:1e-300 big110:1e110; do
  name=${case%%:*}; f=${case#*:}
  $SAGITTA validate "$tmp/$name.bpt" --level 0 --json "$tmp/$name.json" >/dev/null 2>"$tmp/err"; rc=$?
  check "$name: validate exits 0 (got $rc)" "[ $rc = 0 ]"
  check "$name: the interval is weights 1's times $f (relative 1e-9)" \
    "python3 -c \"import json,sys; a=json.load(open('$tmp/w1.json'))['hausdorff']; b=json.load(open('$tmp/$name.json'))['hausdorff']; f=$f; sys.exit(0 if b['upper'] is not None and abs(b['upper']/f-a['upper'])<=1e-9*a['upper'] and abs(b['lower']/f-a['lower'])<=1e-9*a['upper'] and b['lower']<=b['upper'] else 1)\""
done
# A patch collapsed to a line: the mesh lies on it, lower 0 <= upper (it was [inf, 1e-14]).
$SAGITTA validate "$tmp/line.bpt" --level 2 --json "$tmp/line.json" >/dev/null 2>"$tmp/err"; rc=$?
check "line: validate exits 0 (got $rc)" "[ $rc = 0 ]"
check "line: lower <= upper" "json $tmp/line.json 'd[\"hausdorff\"][\"lower\"] <= (d[\"hausdorff\"][\"upper\"] or float(\"inf\"))' | grep -qx True"
check "line: lower is 0" "json $tmp/line.json 'd[\"hausdorff\"][\"lower\"]' | grep -qx 0.0"
# fit on weights 1e-300 needs what weights 1 need (it 'met' 1e-4 with 2 triangles).
$SAGITTA fit "$tmp/cubic1.bpt" --scheme uniform --target-error 1e-4 --json "$tmp/fit1.json" >/dev/null 2>"$tmp/err"
$SAGITTA fit "$tmp/cubic300.bpt" --scheme uniform --target-error 1e-4 --json "$tmp/fit300.json" >/dev/null 2>"$tmp/err"; rc=$?
check "fit weights 1e-300: exit 0 (got $rc)" "[ $rc = 0 ]"
# (the normalised weights are 2^997 x 1e-300, about 1.3, not 1: the same surface, rounded differently)
check "fit weights 1e-300: same triangles and certified error (relative 1e-9) as weights 1" \
  "python3 -c \"import json,sys; a=json.load(open('$tmp/fit1.json')); b=json.load(open('$tmp/fit300.json')); sys.exit(0 if a['triangles']==b['triangles'] and abs(a['certified_error']-b['certified_error'])<=1e-9*a['certified_error'] else 1)\""

# 2-3. No SIGFPE / SIGSEGV on any command (exit codes >= 128 are signals).
for name in big110 w308 point line; do
  $SAGITTA validate "$tmp/$name.bpt" --level 1 --json "$tmp/v.json" >/dev/null 2>"$tmp/err"; rc=$?
  check "validate $name: no signal (exit $rc)" "[ $rc -lt 128 ]"
  $SAGITTA fit "$tmp/$name.bpt" --target-error 1e-3 >/dev/null 2>"$tmp/err"; rc=$?
  check "fit $name: no signal (exit $rc)" "[ $rc -lt 128 ]"
  $SAGITTA run "$tmp/$name.bpt" --out-dir "$tmp/run-$name" --no-report >/dev/null 2>"$tmp/err"; rc=$?
  check "run $name: no signal (exit $rc)" "[ $rc -lt 128 ]"
  $SAGITTA report "$tmp/$name.bpt" --out "$tmp/report-$name" --no-occt >/dev/null 2>"$tmp/err"; rc=$?
  check "report $name: no signal (exit $rc)" "[ $rc -lt 128 ]"
  $SAGITTA peer occt "$tmp/$name.bpt" --deflection 1e-2 --max-depth 2 >/dev/null 2>"$tmp/err"; rc=$?
  check "peer $name: no signal (exit $rc)" "[ $rc -lt 128 ]"
  check "peer $name: exit 0 or one line and exit 2 (exit $rc)" "[ $rc = 0 ] || { [ $rc = 2 ] && [ \$(wc -l < $tmp/err) = 1 ]; }"
done

# 4. Coordinates beyond 1e150: one line naming the file, exit 2, no output (no NaN file).
for name in big200 big308; do
  for command in tessellate validate "peer occt"; do
    out="--out $tmp/out-$name.obj"; [ "$command" = validate ] && out="--json $tmp/out-$name.obj"
    $SAGITTA $command "$tmp/$name.bpt" $out >/dev/null 2>"$tmp/err"; rc=$?
    check "$command $name: exit 2 (got $rc)" "[ $rc = 2 ]"
    check "$command $name: one line naming the file and the limit" "[ \$(wc -l < $tmp/err) = 1 ] && grep -qF '$tmp/$name.bpt' $tmp/err && grep -qF '1e+150' $tmp/err"
    check "$command $name: no output file" "[ ! -e $tmp/out-$name.obj ]"
  done
done

echo "hostile certify: $passed passed, $fail failed"
[ "$fail" = 0 ]
