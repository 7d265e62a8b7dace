#!/usr/bin/env bash
# Hostile input through the sagitta command (issue 9, acceptance 3 and resource limits): a NaN
# coordinate, a truncated patch and degree 26 each make `tessellate` and `validate` exit 2 with one
# line "sagitta: FILE:LINE: problem" and write no output; outputs beyond --max-triangles are refused
# before anything is allocated, for every scheme and both commands.
set -u
fail=0; passed=0
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
check() { if eval "$2"; then passed=$((passed+1)); else echo "FAIL: $1"; sed 's/^/  stderr: /' "$tmp/err" 2>/dev/null; fail=$((fail+1)); fi; }

printf '1\n1 1\n0 0 0\n0 1 0\n1 0 nan\n1 1 0\n' > "$tmp/nan.bpt"
printf '1\n3 3\n0 0 0\n0 1 0\n0 2 0\n' > "$tmp/truncated.bpt"
printf '1\n26 1\n0 0 0\n' > "$tmp/degree26.bpt"
expect_nan="sagitta: $tmp/nan.bpt:5: 'nan' is not a finite number"
expect_truncated="sagitta: $tmp/truncated.bpt:5: file ends early: expected control point 3 of patch 0 of 1"
expect_degree="sagitta: $tmp/degree26.bpt:2: patch 0 of 1 has degree 26x1, outside 1..25"

for command in tessellate validate; do
  for case in nan truncated degree26; do
    file="$tmp/$case.bpt"
    case $case in nan) want=$expect_nan ;; truncated) want=$expect_truncated ;; degree26) want=$expect_degree ;; esac
    if [ $command = tessellate ]; then outputs="--out $tmp/out.obj --stats $tmp/out.json"; else outputs="--json $tmp/out.json --error-ply $tmp/out.ply"; fi
    $SAGITTA $command "$file" --level 1 $outputs >/dev/null 2>"$tmp/err"; rc=$?
    check "$command $case: exit code 2 (got $rc)" "[ $rc = 2 ]"
    check "$command $case: one line" "[ \$(wc -l < $tmp/err) = 1 ]"
    check "$command $case: message names the file and the problem" "[ \"\$(cat $tmp/err)\" = \"$want\" ]"
    check "$command $case: no output written" "[ ! -e $tmp/out.obj ] && [ ! -e $tmp/out.json ] && [ ! -e $tmp/out.ply ] && [ -z \"\$(ls $tmp | grep -v -e '\.bpt$' -e '^err$')\" ]"
  done
done

# Resource limits: the estimate is checked before tessellating, for every scheme and both commands.
limit="more than --max-triangles 1000; lower the level or raise --max-triangles"
for command in tessellate validate; do
  if [ $command = tessellate ]; then outputs="--out $tmp/big.obj"; else outputs="--json $tmp/big.json"; fi
  check "$command uniform refused" "! $SAGITTA $command --scheme uniform --level 6 --max-triangles 1000 $outputs 2>$tmp/err && grep -qF 'this would make 180224 triangles' $tmp/err && grep -qF '$limit' $tmp/err && [ ! -e $tmp/big.obj ] && [ ! -e $tmp/big.json ]"
  check "$command esc refused" "! $SAGITTA $command --scheme esc --level 15 --max-triangles 1000 $outputs 2>$tmp/err && grep -qF 'this would make' $tmp/err && grep -qF '$limit' $tmp/err"
  check "$command pn refused" "! $SAGITTA $command --scheme pn --base-level 1 --level 64 --max-triangles 1000 $outputs 2>$tmp/err && grep -qF 'this would make' $tmp/err && grep -qF '$limit' $tmp/err"
done
# The default limit (200 million) protects without any option: level 12 of the 22-patch default model.
check "default limit" "! $SAGITTA tessellate --level 12 2>$tmp/err && grep -qF 'this would make 738197504 triangles (about 44 GiB), more than --max-triangles 200000000' $tmp/err"
# Counts that would wrap around in 64 bits (2 N^2 patches with N = 2^30 and 8 patches) are refused.
{ echo 8; for k in 0 1 2 3 4 5 6 7; do echo "1 1"; echo "$k 0 0"; echo "$k 1 0"; echo "$((k+1)) 0 0"; echo "$((k+1)) 1 0"; done; } > "$tmp/eight.bpt"
check "no wrap-around" "! $SAGITTA tessellate $tmp/eight.bpt --segments 1073741824 2>$tmp/err && grep -qF 'this would make 18446744073709551616 triangles' $tmp/err"
# --copies is checked before the model is replicated (2 triangles per patch at least).
check "copies checked first" "! $SAGITTA tessellate $tmp/eight.bpt --copies 1000000 --level 0 --max-triangles 1000000 2>$tmp/err && grep -qF 'this would make 16000000 triangles' $tmp/err"
# Levels beyond the limits: the message says why.
check "uniform level 13" "! $SAGITTA tessellate --level 13 2>$tmp/err && grep -qF -- '--level 13 is outside 0..12' $tmp/err && grep -qF '32-bit vertex ids' $tmp/err"
check "esc level 16" "! $SAGITTA tessellate --scheme esc --level 16 2>$tmp/err && grep -qF 'esc --level 16 is outside 0..15' $tmp/err && grep -qF 'GiB' $tmp/err"
check "pn level 4097" "! $SAGITTA tessellate --scheme pn --base-level 0 --level 4097 2>$tmp/err && grep -qF 'in 1..4096' $tmp/err && grep -qF '32-bit vertex ids' $tmp/err"

echo "hostile cli: $passed passed, $fail failed"
[ "$fail" = 0 ]
