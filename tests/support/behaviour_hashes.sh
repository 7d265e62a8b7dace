#!/usr/bin/env bash
# Behaviour fingerprint of the `sagitta` command line: the SHA-256 of every mesh and of every JSON
# report (timings, thread counts and paths removed) that tessellate / validate / fit / scene / report
# write on the tea set, the built-in default model, a CAD file and a triangle mesh, for every scheme.
# A refactor that claims "behaviour does not move" must print the same lines before and after.
# Usage: behaviour_hashes.sh SAGITTA_BINARY SHARED_DATA_DIR [WORK_DIR]  (prints "sha256  name" lines)
set -euo pipefail
bin=$(realpath "$1"); data=$(realpath "$2"); work=${3:-$(mktemp -d)}
mkdir -p "$work"; cd "$work"

# Prints the JSON without fields that measure time or machine: any key with a word seconds, time,
# ms, ratio (of times), throughput, threads, path, file, html, date or machine. Keys are sorted so the hash depends on values only.
strip_json() {
  python3 - "$1" <<'PY'
import json, re, sys
drop = re.compile(r"(^|_)(seconds|time|ms|ratio|throughput|threads|path|file|html|date|machine)($|_)", re.I)
def clean(x):
    if isinstance(x, dict):
        return {k: clean(v) for k, v in x.items() if not drop.search(k)}
    if isinstance(x, list):
        return [clean(v) for v in x]
    return x
print(json.dumps(clean(json.load(open(sys.argv[1]))), sort_keys=True))
PY
}
h() { sha256sum | cut -d' ' -f1; }
record_json() { echo "$(strip_json "$2" | h)  $1"; }
record_mesh() { echo "$(h < "$2")  $1"; }

models=(default "$data/teapot.bpt" "$data/teacup.bpt" "$data/teaspoon.bpt" "$data/cad/wing.brep")
for m in "${models[@]}"; do
  name=$(basename "$m"); name=${name%.*}
  for scheme in uniform esc pn; do
    case $scheme in
      uniform) args=(--scheme uniform --level 3) ;;
      esc) args=(--scheme esc --level 3 --threshold 0.01) ;;
      pn) args=(--scheme pn --level 3 --base-level 1) ;;
    esac
    rc=0
    "$bin" --threads 2 tessellate "$m" "${args[@]}" --out "t_${name}_$scheme.ply" --stats "t_${name}_$scheme.json" \
      >/dev/null 2>"t_${name}_$scheme.err" || rc=$?
    if [[ $rc == 0 ]]; then
      record_mesh "tessellate $name $scheme mesh" "t_${name}_$scheme.ply"
      record_json "tessellate $name $scheme stats" "t_${name}_$scheme.json"
    else  # refused (pn on a CAD part): the exit code and the message, the data folder's path removed
      echo "$( (echo "exit $rc"; sed "s|$data|DATA|g" "t_${name}_$scheme.err") | h)  tessellate $name $scheme exit code and message"
    fi
    rc=0
    "$bin" --threads 2 validate "$m" "${args[@]}" --json "v_${name}_$scheme.json" --error-ply "v_${name}_$scheme.ply" \
      --max-error 0.05 --require-watertight >/dev/null 2>&1 || rc=$?
    echo "$(echo "exit $rc" | h)  validate $name $scheme exit code"
    # (A refused run writes neither file: the hash of the word "absent" stands for it.)
    if [[ -f "v_${name}_$scheme.json" ]]; then record_json "validate $name $scheme report" "v_${name}_$scheme.json"
    else echo "$(echo absent | h)  validate $name $scheme report"; fi
    if [[ -f "v_${name}_$scheme.ply" ]]; then record_mesh "validate $name $scheme error-ply" "v_${name}_$scheme.ply"
    else echo "$(echo absent | h)  validate $name $scheme error-ply"; fi
  done
done
for m in default "$data/teapot.bpt" "$data/cad/wing.brep"; do
  name=$(basename "$m"); name=${name%.*}
  for scheme in uniform esc pn; do
    rc=0
    "$bin" --threads 2 fit "$m" --scheme "$scheme" --target-error 0.01 --json "f_${name}_$scheme.json" \
      --out "f_${name}_$scheme.ply" >/dev/null 2>"f_${name}_$scheme.err" || rc=$?
    echo "$( (echo "exit $rc"; sed "s|$data|DATA|g" "f_${name}_$scheme.err") | h)  fit $name $scheme exit code and message"
    if [[ $rc == 0 ]]; then
      record_json "fit $name $scheme json" "f_${name}_$scheme.json"
      record_mesh "fit $name $scheme mesh" "f_${name}_$scheme.ply"
    fi
  done
done
spot="$data/mesh/spot_control_mesh.obj"
for variant in basic aen; do
  "$bin" --threads 2 tessellate "$spot" --scheme pn --level 3 --pn-variant "$variant" --out "spot_$variant.ply" --stats "spot_$variant.json" >/dev/null
  record_mesh "tessellate spot pn $variant mesh" "spot_$variant.ply"
  record_json "tessellate spot pn $variant stats" "spot_$variant.json"
done
"$bin" --threads 2 validate "$data/teapot.bpt" --mesh "spot_basic.ply" --json v_mesh.json >/dev/null 2>&1 || true
[[ -f v_mesh.json ]] && record_json "validate teapot --mesh spot json" v_mesh.json
"$bin" --threads 2 tessellate default --scheme uniform --level 2 --out default_l2.obj >/dev/null
"$bin" --threads 2 validate default --mesh default_l2.obj --json v_mesh_default.json >/dev/null || true
record_json "validate default --mesh json" v_mesh_default.json
"$bin" --threads 2 run default --out-dir run_out >/dev/null
for f in run_out/*; do
  case $f in
    *.json) record_json "run $(basename "$f")" "$f" ;;
    *.ply|*.obj|*.stl) record_mesh "run $(basename "$f")" "$f" ;;
  esac
done
