# Shell helpers of the whole-part CLI tests (part_cli.sh, part_run_cli.sh): sourced after `set -euo
# pipefail`; FIXTURES names the FreeCAD-built parts' folder (facts.json).
fail() { echo "FAIL: $*"; exit 1; }
# A Python expression over the JSON file $1 (bound to d).
field() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$1" "$2"; }
# The face count a binary PLY declares, and the faces an OBJ lists (independent of our JSON).
ply_faces() { python3 -c "
import sys
for line in open(sys.argv[1], 'rb').read().split(b'end_header')[0].decode().splitlines():
    if line.startswith('element face'): print(line.split()[2])" "$1"; }
obj_faces() { grep -c '^f ' "$1"; }
# A fixture's fact: fact FILE KEY (from FreeCAD's facts.json).
fact() { python3 -c "
import json,sys
d=[p for p in json.load(open(sys.argv[1]))['parts'] if p['file']==sys.argv[2]][0]; print(d[sys.argv[3]])" \
  "$FIXTURES/facts.json" "$1" "$2"; }
