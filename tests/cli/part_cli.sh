#!/usr/bin/env bash
# Whole CAD parts through `sagitta tessellate` and `sagitta validate` (issue 14 item 5). Env:
# SAGITTA, SHARED_DATA; FIXTURES: the FreeCAD-built parts with facts.json (may be empty: those
# checks are skipped). References: the PLY file's own face count, FreeCAD's facts.json (faces,
# trimmed faces, volume), and the B-rep's own free edges for the open shell.
set -euo pipefail
: "${SAGITTA:?}"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/part_lib.sh"

parts=()
[[ -f "${SHARED_DATA:-}/cad/bottle.brep" ]] && parts+=("$SHARED_DATA/cad/bottle.brep")
[[ -f "${SHARED_DATA:-}/cad/step/pr1ct.stp" ]] && parts+=("$SHARED_DATA/cad/step/pr1ct.stp")
if [[ -n "${FIXTURES:-}" && -f "$FIXTURES/facts.json" ]]; then
  parts+=("$FIXTURES/plate_with_holes.brep" "$FIXTURES/open_box_shell.brep" "$FIXTURES/box_cut_by_cylinder.brep")
fi
[[ ${#parts[@]} -gt 0 ]] || { echo "no CAD data: skipping"; exit 0; }

# tessellate: the mesh file holds the triangles the JSON counts; every face tessellated.
for p in "${parts[@]}"; do
  name=$(basename "$p")
  out=$("$SAGITTA" tessellate "$p" --level 2 --out "$tmp/m.ply" --stats "$tmp/s.json") || fail "$name: tessellate exit $?"
  [[ $(printf '%s\n' "$out" | wc -l) == 1 ]] || fail "$name: summary not one line: $out"
  [[ $out == *"faces tessellated"*"closed solids closed"* ]] || fail "$name: summary '$out'"
  [[ $(ply_faces "$tmp/m.ply") == $(field "$tmp/s.json" "d['triangles']") ]] || fail "$name: PLY faces != JSON triangles"
  [[ $(field "$tmp/s.json" "d['faces_tessellated'] == d['faces'] and d['faces_skipped'] == 0") == True ]] \
    || fail "$name: not every face tessellated: $(field "$tmp/s.json" "d['skipped']")"
  [[ $(field "$tmp/s.json" "len(d['face_list']) == d['faces'] and sum(f['triangles'] for f in d['face_list']) == d['triangles']") == True ]] \
    || fail "$name: face_list does not add up"
  if [[ $p == "${FIXTURES:-/nonexistent}"/* ]]; then
    [[ $(field "$tmp/s.json" "d['faces']") == $(fact "$name" faces) ]] || fail "$name: faces differ from FreeCAD's"
    [[ $(field "$tmp/s.json" "d['faces_trimmed']") == $(fact "$name" trimmed_faces) ]] || fail "$name: trimmed faces differ from FreeCAD's"
  fi
done
# The same mesh as OBJ: as many faces.
p=${parts[0]}
"$SAGITTA" tessellate "$p" --level 2 --out "$tmp/m.obj" --stats "$tmp/s.json" >/dev/null
[[ $(obj_faces "$tmp/m.obj") == $(field "$tmp/s.json" "d['triangles']") ]] || fail "OBJ faces != JSON triangles"
# tessellate --certify: a second line with the certificate, the same whole-part interval as validate's
# on the same mesh.
out=$("$SAGITTA" tessellate "$p" --level 2 --certify --stats "$tmp/sc.json") || fail "tessellate --certify exit $?"
[[ $out == *$'\n'"certified: hausdorff in ["*"faces in "* ]] || fail "tessellate --certify: headline '$out'"
"$SAGITTA" validate "$p" --level 2 --json "$tmp/vc.json" >/dev/null || fail "validate exit $?"
[[ $(python3 -c "import json; a=json.load(open('$tmp/sc.json')); b=json.load(open('$tmp/vc.json')); print(a['certified'] and all(a['certificate']['hausdorff'][k] == b['certificate']['hausdorff'][k] for k in ('lower', 'upper')) and len(a['certificate']['faces']) == a['faces'])") == True ]] \
  || fail "tessellate --certify: interval differs from validate's"
# --max-error below a face's certified lower bound: exit 3 with the proven verdict, the faces not yet
# started are skipped (the verdict is known), and the lower bound found is one of the full run's.
set +e
"$SAGITTA" validate "$p" --level 2 --max-error 1e-9 --json "$tmp/me.json" >/dev/null 2>"$tmp/me.err"; code=$?
set -e
[[ $code == 3 ]] || fail "--max-error 1e-9: exit $code"
grep -q "max-error: the distance exceeds it (lower bound above)" "$tmp/me.err" || fail "--max-error 1e-9: $(cat "$tmp/me.err")"
[[ $(python3 -c "import json; d=json.load(open('$tmp/me.json'))['certificate']; f=json.load(open('$tmp/vc.json'))['certificate']; skipped=[x for x in d['faces'] if 'skipped' in x.get('reason', '')]; print(d['note'].startswith('stopped early') and len(skipped) > 0 and d['faces_certified'] + len(skipped) <= d['faces_total'] and 1e-9 < d['hausdorff']['lower'] <= f['hausdorff']['upper'])") == True ]] \
  || fail "--max-error 1e-9: no early stop, or its lower bound above the full run's upper bound"

if [[ -n "${FIXTURES:-}" && -f "$FIXTURES/facts.json" ]]; then
  # A closed solid with trimmed faces: watertight, closed, volume near FreeCAD's, certified on every
  # face (its trimmed planes by the loops route).
  plate="$FIXTURES/plate_with_holes.brep"
  out=$("$SAGITTA" validate "$plate" --level 3 --require-watertight --json "$tmp/v.json") || fail "plate: --require-watertight exit $?"
  [[ $(field "$tmp/v.json" "d['certified']") == True ]] || fail "plate: not certified"
  [[ $out == *$'\n'"certified: hausdorff in ["* ]] || fail "plate: headline '$out'"
  [[ $(field "$tmp/v.json" "d['watertight'] and d['validation']['crack_edges'] == 0") == True ]] || fail "plate: not watertight"
  volume=$(fact plate_with_holes.brep volume)
  [[ $(field "$tmp/v.json" "all(v['mesh_closed'] for v in d['validation']['volumes']) and len(d['validation']['volumes']) == 1") == True ]] \
    || fail "plate: the solid's mesh is not closed"
  [[ $(field "$tmp/v.json" "abs(d['validation']['volumes'][0]['mesh_volume'] - $volume) <= 2e-2 * $volume") == True ]] \
    || fail "plate: mesh volume far from FreeCAD's $volume"
  [[ $(field "$tmp/v.json" "sum(f['route'] == 'loops' and f['certified'] for f in d['certificate']['faces'] if f['trimmed']) == d['faces_trimmed'] > 0") == True ]] \
    || fail "plate: trimmed faces not certified by the loops route"
  [[ $(field "$tmp/v.json" "all(f['lower'] <= d['certificate']['hausdorff']['upper'] for f in d['certificate']['faces'])") == True ]] \
    || fail "plate: a face's lower bound above the part's upper bound"
  # --max-error: met far above the bound (exit 0), failed below it (exit 3).
  "$SAGITTA" validate "$plate" --level 2 --max-error 1e9 >/dev/null 2>&1 || fail "plate: --max-error 1e9 exit $?"
  set +e
  "$SAGITTA" validate "$plate" --level 2 --max-error 1e-9 >/dev/null 2>&1; code=$?
  set -e
  [[ $code == 3 ]] || fail "plate: --max-error 1e-9: exit $code"

  # fit: a whole part to 2e-4 of its diagonal (FreeCAD's). The certified error meets the target, the
  # chosen segments are the smallest that do (one fewer misses, or it is 1), the mesh written is the
  # one measured, and a direct validate with the same segments and edge tolerance certifies the same.
  bbox=$(fact plate_with_holes.brep bbox_diag)
  "$SAGITTA" fit "$plate" --target-error 2e-4 --relative --json "$tmp/fit.json" --out "$tmp/fit.ply" >/dev/null \
    || fail "plate: fit exit $?"
  [[ $(field "$tmp/fit.json" "d['met'] and d['certified'] and d['certified_error'] <= d['target_error'] and abs(d['target_error'] - 2e-4 * $bbox) <= 1e-6 * d['target_error']") == True ]] \
    || fail "plate: fit did not meet its target: $(field "$tmp/fit.json" "(d['target_error'], d['certified_error'])")"
  [[ $(ply_faces "$tmp/fit.ply") == $(field "$tmp/fit.json" "d['triangles']") ]] || fail "plate: fit PLY faces != JSON triangles"
  [[ $(field "$tmp/fit.json" "d['segments'] == 1 or any(s['segments'] == d['segments'] - 1 and not (s['certified'] and s['upper'] <= d['target_error']) for s in d['steps'])") == True ]] \
    || fail "plate: fit's segments are not the smallest that meet the target"
  segs=$(field "$tmp/fit.json" "d['segments']"); tol=$(field "$tmp/fit.json" "repr(d['edge_tolerance'])")
  "$SAGITTA" validate "$plate" --segments "$segs" --edge-tolerance "$tol" --json "$tmp/fv.json" >/dev/null || fail "plate: validate of the fit exit $?"
  [[ $(field "$tmp/fv.json" "d['certificate']['hausdorff']['upper']") == $(field "$tmp/fit.json" "d['certified_error']") ]] \
    || fail "plate: fit's certified error differs from a direct validate"
  # --scheme esc on a whole part is refused with exit code 2 and one line.
  set +e
  "$SAGITTA" fit "$plate" --scheme esc --target-error 1 >/dev/null 2>"$tmp/err"; code=$?
  set -e
  [[ $code == 2 && $(wc -l < "$tmp/err") == 1 ]] || fail "plate: fit --scheme esc: exit $code, $(cat "$tmp/err")"

  # --edge-tolerance t: each hole's circles (r 6 through, r 4 blind; two circles each) need at least
  # pi / acos(1 - t / r) chords of sagitta <= t, so at least that many edge vertices.
  "$SAGITTA" tessellate "$plate" --level 1 --edge-tolerance 0.01 --stats "$tmp/e.json" >/dev/null || fail "plate: --edge-tolerance"
  [[ $(field "$tmp/e.json" "d['edge_vertices'] >= sum(2 * __import__('math').ceil(__import__('math').pi / __import__('math').acos(1 - 0.01 / r)) for r in (6, 4))") == True ]] \
    || fail "plate: too few edge vertices for --edge-tolerance 0.01: $(field "$tmp/e.json" "d['edge_vertices']")"
  set +e
  "$SAGITTA" tessellate "$plate" --level 1 --edge-tolerance -1 >/dev/null 2>&1; code=$?
  set -e
  [[ $code == 2 ]] || fail "a negative --edge-tolerance: exit $code"

  # The open shell: its rim is model boundary, not a crack.
  shell="$FIXTURES/open_box_shell.brep"
  "$SAGITTA" validate "$shell" --level 2 --require-watertight --json "$tmp/o.json" >/dev/null || fail "open shell: exit $?"
  [[ $(field "$tmp/o.json" "d['validation']['crack_edges'] == 0 and d['validation']['model_boundary_edges'] > 0") == True ]] \
    || fail "open shell: rim not model boundary: $(field "$tmp/o.json" "d['validation']")"
fi

# A part with untrimmed faces only can be certified, face by face, and then says so.
if [[ -f "${SHARED_DATA:-}/cad/shell1.brep" ]]; then
  out=$("$SAGITTA" validate "$SHARED_DATA/cad/shell1.brep" --level 1 --max-depth 4 --json "$tmp/c.json") || fail "shell1: exit $?"
  if [[ $(field "$tmp/c.json" "d['faces_trimmed']") == 0 ]]; then
    [[ $(field "$tmp/c.json" "d['certified'] and d['certificate']['faces_certified'] == d['faces']") == True ]] \
      || fail "shell1 (untrimmed): not certified: $(field "$tmp/c.json" "d['certificate']['faces_not_certified'][:3]")"
    [[ $out == *$'\n'"certified: hausdorff in ["* ]] || fail "shell1: headline '$out'"
  fi
  c="d['certificate']"
  [[ $(field "$tmp/c.json" "sum(f['certified'] for f in $c['faces']) == $c['faces_certified'] == d['faces'] - len($c['faces_not_certified'])") == True ]] \
    || fail "shell1: certified and not certified faces do not add up"
  if [[ $(field "$tmp/c.json" "$c['faces_certified']") != 0 ]]; then
    # Certified faces' bounds never exceed the part's largest; every face's lower bound lies below it.
    [[ $(field "$tmp/c.json" "max(f['upper'] for f in $c['faces'] if f['certified']) == $c['certified_faces_upper'] and all(f['lower'] <= f['upper'] for f in $c['faces'] if f['certified'])") == True ]] \
      || fail "shell1: a face's bound above the certified faces' largest, or below its lower bound"
  fi
fi

# Malformed and truncated CAD files: exit 2, one line naming the file; an existing --out untouched.
head -c 2000 "${parts[0]}" > "$tmp/cut.brep"
printf 'ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((\x27x\x27),\x272;1\x27);\n' > "$tmp/cut.step"
if [[ -f "${SHARED_DATA:-}/cad/step/pr1ct.stp" ]]; then
  size=$(stat -c %s "$SHARED_DATA/cad/step/pr1ct.stp")
  head -c $((size / 2)) "$SHARED_DATA/cad/step/pr1ct.stp" > "$tmp/half.stp"
fi
echo keep > "$tmp/keep.ply"
for f in "$tmp/cut.brep" "$tmp/cut.step" "$tmp"/half.stp; do
  [[ -f $f ]] || continue
  for cmd in tessellate validate; do
    set +e
    err=$("$SAGITTA" $cmd "$f" --level 1 $([[ $cmd == tessellate ]] && echo --out "$tmp/keep.ply") 2>&1 >/dev/null); code=$?
    set -e
    [[ $code != 0 ]] || fail "$cmd $f: exit 0 on a malformed file"
    [[ $err == "sagitta: $f"* ]] || fail "$cmd $f: message '$err'"
    [[ $(printf '%s\n' "$err" | wc -l) == 1 ]] || fail "$cmd $f: more than one line: $err"
  done
done
[[ $(cat "$tmp/keep.ply") == keep ]] || fail "a failed tessellate touched --out"
# No temporary file left beside the outputs.
[[ -z $(find "$tmp" -name '*.tmp*' -o -name '.*~') ]] || fail "temporary files left: $(ls -a "$tmp")"

# pn on a part: refused with one line naming the file (fit of parts: the plate above; run and
# report take parts: part_run_cli.sh).
p=${parts[0]}
for args in "tessellate $p --scheme pn --level 2 --out $tmp/f.ply"; do
  set +e
  err=$("$SAGITTA" $args 2>&1 >/dev/null); code=$?
  set -e
  [[ $code == 2 ]] || fail "'$args': exit $code, expected 2"
  [[ $(printf '%s\n' "$err" | wc -l) == 1 && $err == *"$p"* ]] || fail "'$args': message '$err'"
done
[[ ! -e "$tmp/f.ply" ]] || fail "a refused tessellation wrote its mesh"
echo "part_cli: all checks passed"
