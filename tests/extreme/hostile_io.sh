#!/usr/bin/env bash
# Hostile files, paths, signals and options through the sagitta command (issue 20, items 6, 8, 10,
# 11): devices and junk as inputs are refused after one chunk with one line naming the file and
# line; an output that is an input (or another output) is refused before anything is written; a
# signal while writing leaves no temporary file; outputs get the usual file modes; RIB transforms
# that are singular or cannot be followed are refused; option errors exit 2 with one line.
set -u
fail=0; passed=0
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
check() { if eval "$2"; then passed=$((passed+1)); else echo "FAIL: $1"; sed 's/^/  stderr: /' "$tmp/err" 2>/dev/null; fail=$((fail+1)); fi; }
# Runs sagitta with stderr in $tmp/err, at most 60 s and 4 GB of address space. An AddressSanitizer
# build runs without the address-space cap (its shadow memory alone reserves terabytes of address
# space); the Release run of this test keeps it.
if ldd "$SAGITTA" 2>/dev/null | grep -q libasan; then cap="true"; else cap="ulimit -v 4000000"; fi
run() { ( $cap; timeout 60 $SAGITTA "$@" ) >/dev/null 2>"$tmp/err"; }
one_line() { [ "$(wc -l < "$tmp/err")" = 1 ] && grep -q '^sagitta: ' "$tmp/err"; }

printf '1\n1 1\n0 0 0\n0 1 0\n1 0 0\n1 1 0\n' > "$tmp/flat.bpt"

# --- item 6: devices and junk as text inputs --------------------------------------------------
ln -s /dev/zero "$tmp/zero.bpt"; ln -s /dev/urandom "$tmp/random.rib"; ln -s /dev/zero "$tmp/zero.obj"
ln -s /dev/urandom "$tmp/random.json"; ln -s /dev/zero "$tmp/zero.ply"; ln -s /dev/zero "$tmp/zero.stl"
run tessellate "$tmp/zero.bpt" --level 1; rc=$?
check "/dev/zero as .bpt: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'zero.bpt:1: contains a NUL byte' $tmp/err"
run validate "$tmp/random.rib"; rc=$?
check "/dev/urandom as .rib: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qE 'random.rib:[0-9]+: contains a NUL byte' $tmp/err"
run validate "$tmp/flat.bpt" --mesh "$tmp/zero.obj"; rc=$?
check "/dev/zero as .obj mesh: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'zero.obj:1: contains a NUL byte' $tmp/err"
run validate "$tmp/flat.bpt" --mesh "$tmp/zero.ply"; rc=$?
check "/dev/zero as .ply mesh: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'not a PLY file' $tmp/err"
run validate "$tmp/flat.bpt" --mesh "$tmp/zero.stl"; rc=$?
check "/dev/zero as .stl mesh: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'not an STL file' $tmp/err"
run scene "$tmp/random.json"; rc=$?
check "/dev/urandom as a scene: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qE 'random.json:[0-9]+: contains a NUL byte' $tmp/err"
# A line of 100000 bytes without a newline or NUL: refused by its length, not parsed.
{ echo 1; head -c 100000 /dev/zero | tr '\0' '1'; echo; } > "$tmp/long.bpt"
run tessellate "$tmp/long.bpt" --level 1; rc=$?
check "over-long line: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'long.bpt:2: line longer than 65536 bytes' $tmp/err"
# OBJ n-gons (fan) and negative (relative) indices per the OBJ spec: 3 + 1 triangles read.
printf 'v 0 0 0\nv 0.5 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4 5\nv 0.5 0.5 0\nf -6 -4 -1\n' > "$tmp/ngon.obj"
( timeout 60 $SAGITTA tessellate "$tmp/ngon.obj" --scheme pn --level 1 > "$tmp/ngon.out" 2>"$tmp/err" ); rc=$?
check "OBJ n-gon and negative indices read (got $rc)" "[ $rc = 0 ] && grep -q '^pn: 4 input triangles' $tmp/ngon.out"

# --- item 8: an output that is an input ---------------------------------------------------------
mkdir "$tmp/s"; cp "$tmp/flat.bpt" "$tmp/s/model.bpt"; cp "$tmp/s/model.bpt" "$tmp/s/model.orig"
cat > "$tmp/s/scene.json" <<'JSON'
{"models": {"m": "model.bpt"}, "instances": [{"model": "m"}],
 "camera": {"eye": [0, 0, 10], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y_degrees": 45, "width": 64, "height": 64},
 "tolerance_pixels": 1}
JSON
run scene "$tmp/s/scene.json" --json "$tmp/s/model.bpt"; rc=$?
check "scene --json onto the scene's model: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'refusing to overwrite the input' $tmp/err && cmp -s $tmp/s/model.bpt $tmp/s/model.orig"
run scene "$tmp/s/scene.json" --out "$tmp/s/../s/./model.bpt.obj" --json "$tmp/s/model.bpt.obj"; rc=$?
check "scene --out and --json the same file: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF -- '--out and --json name the same file' $tmp/err && [ ! -e $tmp/s/model.bpt.obj ]"
run tessellate "$tmp/flat.bpt" --level 1 --out "$tmp/a.obj" --stats "$tmp/./a.obj"; rc=$?
check "tessellate --out a.obj --stats a.obj: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'name the same file' $tmp/err && [ ! -e $tmp/a.obj ]"
ln -s "$tmp/flat.bpt" "$tmp/link.json"
run tessellate "./$(realpath --relative-to=. "$tmp/flat.bpt")" --level 1 --stats "$tmp/link.json"; rc=$?
check "tessellate --stats through a symlink to the input: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'refusing to overwrite the input' $tmp/err"
# `run` writes fixed names into --out-dir: an input that is one of them (here through a symlink) is refused.
mkdir "$tmp/out"; cp "$tmp/flat.bpt" "$tmp/out/run.json"; ln -s "$tmp/out/run.json" "$tmp/in.bpt"
run run "$tmp/in.bpt" --out-dir "$tmp/out" --no-report; rc=$?
check "run: input is OUT_DIR/run.json: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'refusing to overwrite the input' $tmp/err && cmp -s $tmp/out/run.json $tmp/flat.bpt"

# --- item 10: signals and file modes --------------------------------------------------------------
mkdir "$tmp/sig"
$SAGITTA tessellate --level 8 --out "$tmp/sig/big.obj" >/dev/null 2>&1 & pid=$!
shopt -s nullglob dotglob
seen=0
deadline=$((SECONDS + 120))
while [ $SECONDS -lt $deadline ]; do  # poll (no fork) until the temporary file appears
  t=("$tmp"/sig/.big.obj.tmp-*); if [ ${#t[@]} -gt 0 ]; then seen=1; break; fi
  kill -0 $pid 2>/dev/null || break
done
kill -TERM $pid 2>/dev/null; wait $pid; rc=$?
left=("$tmp"/sig/.big.obj.tmp-*)
check "SIGTERM while writing: the temporary file was seen" "[ $seen = 1 ]"
check "SIGTERM while writing: exit status non-zero (got $rc)" "[ $rc != 0 ]"
check "SIGTERM while writing: no temporary file left (${left[*]:-none})" "[ ${#left[@]} = 0 ] && [ ! -e $tmp/sig/big.obj ]"
shopt -u nullglob dotglob
( umask 022; $SAGITTA tessellate "$tmp/flat.bpt" --level 0 --out "$tmp/new.obj" >/dev/null 2>"$tmp/err" )
check "a new output gets 0666 minus the umask (0644)" "[ \$(stat -c %a $tmp/new.obj) = 644 ]"
echo old > "$tmp/old.obj"; chmod 664 "$tmp/old.obj"
( umask 077; $SAGITTA tessellate "$tmp/flat.bpt" --level 0 --out "$tmp/old.obj" >/dev/null 2>"$tmp/err" )
check "a replaced output keeps its mode (0664)" "[ \$(stat -c %a $tmp/old.obj) = 664 ] && grep -q '^v ' $tmp/old.obj"
patch='Patch "bilinear" "P" [0 0 0  1 0 0  0 1 0  1 1 0]'
printf 'Scale 0 0 0\n%s\n' "$patch" > "$tmp/scale0.rib"
run tessellate "$tmp/scale0.rib" --level 1 --out "$tmp/scale0.obj"; rc=$?
check "RIB Scale 0 0 0: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'scale0.rib:1: Scale by zero makes the transformation singular' $tmp/err && [ ! -e $tmp/scale0.obj ]"
printf 'ConcatTransform [1 0 0 0  0 1 0 0  1 1 0 0  0 0 0 1]\n%s\n' "$patch" > "$tmp/flat3.rib"
run tessellate "$tmp/flat3.rib" --level 1; rc=$?
check "RIB singular ConcatTransform: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'flat3.rib:1: ConcatTransform matrix is singular' $tmp/err"
for request in 'ObjectBegin 1' 'MotionBegin [0 1]' 'Skew 45 0 1 0 1 0 0'; do
  printf '%s\n%s\n' "$request" "$patch" > "$tmp/request.rib"
  run tessellate "$tmp/request.rib" --level 1; rc=$?
  check "RIB ${request%% *}: exit 2 (got $rc)" "[ $rc = 2 ] && one_line && grep -qF \"request.rib:1: ${request%% *} is not supported\" $tmp/err"
done
printf 'Translate 5 0 0\nTransform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 1 1]\n%s\n' "$patch" > "$tmp/transform.rib"
run tessellate "$tmp/transform.rib" --level 0 --out "$tmp/transform.obj"; rc=$?
check "RIB Transform replaces the current transformation (got $rc)" "[ $rc = 0 ] && grep -q '^v 2 2 1$' $tmp/transform.obj && ! grep -q '^v 6 ' $tmp/transform.obj"

# --- item 11: option errors -----------------------------------------------------------------------
run tessellate --level 99999999999; rc=$?
check "--level 99999999999: exit 2, one line (got $rc)" "[ $rc = 2 ] && one_line && grep -qF -- '--level' $tmp/err"
run --threads -1 tessellate; rc=$?
check "--threads -1: exit 2, readable (got $rc)" "[ $rc = 2 ] && one_line && grep -qF 'not in range 0 to 4096' $tmp/err && ! grep -qF 17976931348623157 $tmp/err"
run tessellate --no-such-option; rc=$?
check "unknown option: exit 2 (got $rc)" "[ $rc = 2 ] && one_line"
run; rc=$?
check "no subcommand: exit 2 (got $rc)" "[ $rc = 2 ] && one_line"
$SAGITTA tessellate --help > "$tmp/help" 2>&1; rc=$?
check "--help: exit 0 with the usage (got $rc)" "[ $rc = 0 ] && grep -q -- '--level' $tmp/help"

echo "hostile io: $passed passed, $fail failed"
[ "$fail" = 0 ]
