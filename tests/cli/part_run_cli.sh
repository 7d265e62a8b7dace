#!/usr/bin/env bash
# Whole CAD parts through `sagitta run` and `sagitta report` (issue 14 item 5). Env: SAGITTA,
# SHARED_DATA; FIXTURES: the FreeCAD-built parts with facts.json (may be empty: those checks are
# skipped). References: the PLY files' own face counts, FreeCAD's facts.json (faces, trimmed faces,
# box diagonal, volume, Euler characteristic per solid) and `sagitta tessellate` at the same level.
set -euo pipefail
: "${SAGITTA:?}"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/part_lib.sh"

pr1ct="${SHARED_DATA:-/nonexistent}/cad/step/pr1ct.stp"
plate="${FIXTURES:-/nonexistent}/plate_with_holes.brep"
parts=()
[[ -f $pr1ct ]] && parts+=("$pr1ct")
[[ -n "${FIXTURES:-}" && -f "$FIXTURES/facts.json" ]] && parts+=("$plate")
[[ ${#parts[@]} -gt 0 ]] || { echo "no CAD data: skipping"; exit 0; }

# run: both meshes written with the triangles the JSON counts, every face listed once with its
# certificate state, the HTML with the per-solid and per-face tables; one summary line per scheme.
for p in "${parts[@]}"; do
  name=$(basename "$p"); d="$tmp/run_$name"
  out=$("$SAGITTA" run "$p" --level 3 --out-dir "$d") || fail "$name: run exit $?"
  for i in 0 1; do
    scheme=$(field "$d/run.json" "d['runs'][$i]['scheme']")
    [[ $(ply_faces "$d/$scheme.ply") == $(field "$d/run.json" "d['runs'][$i]['triangles']") ]] \
      || fail "$name $scheme: PLY faces != JSON triangles"
    r="d['runs'][$i]"
    [[ $(field "$d/run.json" "$r['faces_tessellated'] == $r['faces'] and len($r['face_list']) == $r['faces']") == True ]] \
      || fail "$name $scheme: not every face listed"
    [[ $(field "$d/run.json" "sorted(f['face'] for f in $r['face_list']) == sorted('Face %d' % (k + 1) for k in range($r['faces']))") == True ]] \
      || fail "$name $scheme: face names"
    [[ $(field "$d/run.json" "sum(f['triangles'] for f in $r['face_list']) == $r['triangles']") == True ]] \
      || fail "$name $scheme: face triangles do not add up"
    # A certified face carries its bound, any other face its reason (never a number).
    [[ $(field "$d/run.json" "all(('upper' in f) == f['certified'] and ('reason' in f) != f['certified'] for f in $r['face_list'])") == True ]] \
      || fail "$name $scheme: a face's certificate fields"
    [[ $(field "$d/run.json" "$r['certified'] == all(f['certified'] for f in $r['face_list'])") == True ]] \
      || fail "$name $scheme: part certified while a face is not (or the reverse)"
    line=$(printf '%s\n' "$out" | grep "^  $scheme: ") || fail "$name: no line for $scheme in '$out'"
    [[ $line == *"faces tessellated"*"triangles in"*"closed solids closed"* ]] || fail "$name $scheme: line '$line'"
  done
  [[ $(ply_faces "$d/uniform.ply") == $("$SAGITTA" tessellate "$p" --level 3 --stats "$tmp/t.json" >/dev/null && field "$tmp/t.json" "d['triangles']") ]] \
    || fail "$name: run's uniform mesh differs from tessellate --level 3"
  # The whole-part fit (issue 15): E = 1e-3 of the box diagonal, met with every face certified, its
  # mesh written with the triangles fit.json counts, and the same mesh `sagitta fit PART` makes for E.
  [[ $(field "$d/run.json" "d['fit']['met'] and d['fit']['certified'] and d['fit']['certified_error'] <= d['fit']['target_error'] and abs(d['fit']['target_error'] - 1e-3 * d['box_diagonal']) <= 1e-12 * d['box_diagonal']") == True ]] \
    || fail "$name: fit not met at 1e-3 of the diagonal"
  [[ $(ply_faces "$d/fit.ply") == $(field "$d/fit.json" "d['triangles']") ]] || fail "$name: fit.ply faces != fit.json triangles"
  [[ $(field "$d/fit.json" "len(d['part']['certificate']['faces']) == d['part']['faces']") == True ]] || fail "$name: fit.json faces"
  [[ $out == *"fit the whole part to certified error <= "*"(meets the target)"* ]] || fail "$name: fit line in '$out'"
  target=$(field "$d/run.json" "repr(d['fit']['target_error'])")
  "$SAGITTA" fit "$p" --target-error "$target" --json "$tmp/fit.json" >/dev/null || fail "$name: sagitta fit exit $?"
  [[ $(field "$tmp/fit.json" "d['triangles']") == $(field "$d/fit.json" "d['triangles']") ]] \
    || fail "$name: run's fit differs from sagitta fit --target-error $target"
  [[ ! -e "$d/pn.ply" ]] || fail "$name: pn mesh written for a part"
  [[ $(field "$d/report.json" "d['models'][0]['fit']['triangles']") == $(field "$d/fit.json" "d['triangles']") ]] \
    || fail "$name: the report's fit is not run's fit"
  [[ -f "$d/report.html" && -f "$d/report.json" ]] || fail "$name: no report"
  grep -q '<table class="faces">' "$d/report.html" || fail "$name: no per-face table in the HTML"
  grep -q '<th>&chi;</th>' "$d/report.html" || fail "$name: no per-solid table in the HTML"
  for f in $(field "$d/run.json" "' '.join(f['face'].replace(' ', '_') for f in d['runs'][0]['face_list'])"); do
    grep -q "<td class=\"l\">${f/_/ }</td>" "$d/report.html" || fail "$name: ${f/_/ } not in the HTML"
  done
done

if [[ -n "${FIXTURES:-}" && -f "$FIXTURES/facts.json" ]]; then
  d="$tmp/run_plate_with_holes.brep"
  # Trimmed faces are certified too (the loops route): both runs certified on every face, on stdout,
  # in run.json and report.json (a level is certified exactly when it has an interval).
  out=$("$SAGITTA" run "$plate" --level 2 --out-dir "$tmp/plate2")
  [[ $out != *"not certified"* ]] || fail "plate: stdout says not certified: $out"
  [[ $(field "$tmp/plate2/run.json" "[r['certified'] for r in d['runs']]") == "[True, True]" ]] || fail "plate: not certified in run.json"
  [[ $(field "$tmp/plate2/report.json" "all((r['certified_hausdorff'] is not None) == r['certified'] for r in d['models'][0]['levels'])") == True ]] \
    || fail "plate: report.json's levels: certified without an interval, or the reverse"
  # FreeCAD's facts: faces, trimmed faces, box diagonal (ESC's threshold is 1e-3 of it), volume, chi.
  r="d['runs'][0]"
  [[ $(field "$d/run.json" "$r['faces']") == $(fact plate_with_holes.brep faces) ]] || fail "plate: faces differ from FreeCAD's"
  [[ $(field "$d/run.json" "$r['faces_trimmed']") == $(fact plate_with_holes.brep trimmed_faces) ]] || fail "plate: trimmed faces differ"
  bbox=$(fact plate_with_holes.brep bbox_diag)
  [[ $(field "$d/run.json" "abs(d['box_diagonal'] - $bbox) <= 1e-6 * $bbox and d['runs'][1]['setting'] == 'L 3, rho %.3g' % (1e-3 * $bbox)") == True ]] \
    || fail "plate: box diagonal $(field "$d/run.json" "d['box_diagonal']") or ESC setting, FreeCAD's diagonal $bbox"
  volume=$(fact plate_with_holes.brep volume)
  chi=$(fact plate_with_holes.brep euler_per_solid)
  for i in 0 1; do
    [[ $(field "$d/run.json" "[c['euler_characteristic'] for c in d['runs'][$i]['validation']['solid_checks']]") == "$chi" ]] \
      || fail "plate: chi per solid differs from FreeCAD's $chi"
    [[ $(field "$d/run.json" "abs(d['runs'][$i]['validation']['volumes'][0]['mesh_volume'] - $volume) <= 2e-2 * $volume") == True ]] \
      || fail "plate: mesh volume far from FreeCAD's $volume"
  done
  grep -q 'loops' "$d/report.html" || fail "plate: the faces' certificate routes not in the HTML"
fi

# report: one row per level (1..4) in the JSON and the HTML; triangles as tessellate gives them; a
# Hausdorff number only for a level where every face is certified.
if [[ -f $pr1ct ]]; then
  out=$("$SAGITTA" report "$pr1ct" --out "$tmp/rep") || fail "report pr1ct: exit $?"
  m="d['models'][0]"
  [[ $(field "$tmp/rep/report.json" "$m['kind'] == 'part' and [r['level'] for r in $m['levels']] == [1, 2, 3, 4]") == True ]] \
    || fail "report pr1ct: levels $(field "$tmp/rep/report.json" "$m.get('levels')")"
  for level in 1 2 3 4; do
    "$SAGITTA" tessellate "$pr1ct" --level $level --stats "$tmp/t.json" >/dev/null
    triangles=$(field "$tmp/t.json" "d['triangles']")
    [[ $(field "$tmp/rep/report.json" "$m['levels'][$level - 1]['triangles']") == "$triangles" ]] \
      || fail "report pr1ct level $level: triangles differ from tessellate's $triangles"
    grep -q "<tr><td>$level</td><td>$triangles</td>" "$tmp/rep/report.html" || fail "report pr1ct: no HTML row for level $level"
    [[ $(printf '%s\n' "$out" | grep -c "pr1ct.stp level $level: $triangles triangles") == 1 ]] || fail "report pr1ct: stdout '$out'"
  done
  [[ $(field "$tmp/rep/report.json" "all((r['certified_hausdorff'] is None) != r['certified'] and r['faces_certified'] <= r['faces'] for r in $m['levels'])") == True ]] \
    || fail "report pr1ct: certified_hausdorff without a certificate"
  [[ $(field "$tmp/rep/report.json" "all(r['certified'] == (r['faces_certified'] == r['faces']) for r in $m['levels'])") == True ]] \
    || fail "report pr1ct: certified does not match the faces certified"
  [[ $(grep -o '<tr><td>[0-9]</td>' "$tmp/rep/report.html" | wc -l) == 4 ]] || fail "report pr1ct: not 4 level rows in the HTML"
  # The whole-part fit at 1e-3 of the box diagonal: met, its row in the HTML and its line on stdout,
  # the same mesh as `sagitta fit` at that target.
  [[ $(field "$tmp/rep/report.json" "$m['fit']['met'] and $m['fit']['certified_error'] <= $m['fit']['target_error'] and abs($m['fit']['target_error'] - 1e-3 * $m['box_diagonal']) <= 1e-12 * $m['box_diagonal']") == True ]] \
    || fail "report pr1ct: fit $(field "$tmp/rep/report.json" "$m.get('fit')")"
  fit_triangles=$(field "$tmp/rep/report.json" "$m['fit']['triangles']")
  grep -q "<h3>Fit to a certified error of" "$tmp/rep/report.html" && grep -q "<tr><td>$fit_triangles</td>" "$tmp/rep/report.html" \
    || fail "report pr1ct: no fit table in the HTML"
  [[ $(printf '%s\n' "$out" | grep -c "pr1ct.stp fit to .*: $fit_triangles triangles, certified Hausdorff <= .* (meets the target)") == 1 ]] \
    || fail "report pr1ct: fit line in '$out'"
  "$SAGITTA" fit "$pr1ct" --target-error "$(field "$tmp/rep/report.json" "repr($m['fit']['target_error'])")" --json "$tmp/fit2.json" >/dev/null
  [[ $(field "$tmp/fit2.json" "d['triangles']") == "$fit_triangles" ]] || fail "report pr1ct: fit differs from sagitta fit"
  # A part among patch models: each in the order given, the patch model swept as before.
  "$SAGITTA" report "$pr1ct" default --no-occt --out "$tmp/mix" >/dev/null || fail "report pr1ct default: exit $?"
  [[ $(field "$tmp/mix/report.json" "[(m.get('kind'), m['name']) for m in d['models']]") == "[('part', 'pr1ct.stp'), (None, 'default')]" ]] \
    || fail "report pr1ct default: models $(field "$tmp/mix/report.json" "[m['name'] for m in d['models']]")"
  [[ $(field "$tmp/mix/report.json" "len(d['models'][1]['points']) > 0 and 'uniform' in d['models'][1]['schemes']") == True ]] \
    || fail "report pr1ct default: the patch model's sweep is missing"
  grep -q 'pr1ct.stp &mdash; whole CAD part' "$tmp/mix/report.html" && grep -q '<h2>default &mdash;' "$tmp/mix/report.html" \
    || fail "report pr1ct default: a section is missing from the HTML"
fi
echo "part_run_cli: all checks passed"
