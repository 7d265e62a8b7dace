#!/usr/bin/env bash
# Runs the install steps of docs/FREECAD.md verbatim and checks what they installed.
#   test_install.sh SOURCE BUILD     the steps on an existing build folder (ctest: freecad_install); the
#                                    commands run in a scratch folder where `build` links to BUILD
#   test_install.sh --clone SOURCE   a clean clone of SOURCE's HEAD: the configure step too (minutes)
# The steps are the indented lines after the markers `<!-- install-test: configure|user|package -->`.
# Checks: the user steps put exactly plugin/freecad's *.py and icons/*.svg (byte-identical) and the
# _sagitta module into the user Mod folder of a throw-away HOME, and nothing anywhere else; the package
# steps put the same files under DESTDIR's usr/share/freecad/Mod/Sagitta and nothing else; with
# FreeCAD installed, freecadcmd imports the installed SagittaCore and _sagitta from each Mod folder.
set -euo pipefail
if [ "$1" = --clone ]; then mode=clone source=$(cd "$2" && pwd); else mode=build source=$(cd "$1" && pwd) build=$(cd "$2" && pwd); fi
doc=$source/docs/FREECAD.md
work=$(mktemp -d /tmp/sagitta-install-test.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "test_install.sh: FAILED: $*" >&2; exit 1; }

steps() {  # the indented command lines after <!-- install-test: $1 -->, up to the next blank line
  awk -v marker="<!-- install-test: $1 -->" '
    $0 == marker { on = 1; next }
    on && /^    / { sub(/^    /, ""); print; seen = 1; next }
    on && seen { exit }' "$doc"
}
run_steps() {
  local text
  text=$(steps "$1")
  [ -n "$text" ] || fail "docs/FREECAD.md has no '$1' install steps"
  echo "--- docs/FREECAD.md, $1 steps:"; echo "$text"
  (cd "$tree" && env -u XDG_DATA_HOME HOME="$work/home" bash -euo pipefail -c "$text") || fail "the $1 steps failed"
}

if [ "$mode" = clone ]; then
  git clone --quiet "$source" "$work/tree"
  tree=$work/tree
  run_steps configure
else
  mkdir "$work/tree"
  tree=$work/tree
  ln -s "$build" "$tree/build"
fi
mkdir -p "$work/home"

# What plugin/freecad holds, the expected content of every Mod folder (module aside).
expected=$(cd "$source/plugin/freecad" && find . -type f \( -name '*.py' -o -name '*.svg' \) -not -path '*/__pycache__/*' | sort)
check_mod() {  # check_mod FOLDER ROOT: FOLDER holds exactly the workbench; ROOT holds nothing else
  local mod=$1 root=$2 f
  [ -d "$mod" ] || fail "nothing installed in $mod"
  local got
  got=$(cd "$mod" && find . -type f -not -name '_sagitta*.so' | sort)
  [ "$got" = "$expected" ] || fail "$mod holds $(echo $got), expected $(echo $expected)"
  for f in $expected; do cmp -s "$source/plugin/freecad/$f" "$mod/$f" || fail "$mod/$f differs from plugin/freecad/$f"; done
  [ "$(ls "$mod"/_sagitta*.so | wc -l)" = 1 ] || fail "no _sagitta module in $mod"
  local others
  others=$(find "$root" -type f -not -path "$mod/*" | head -5)
  [ -z "$others" ] || fail "installed outside $mod: $others"
  echo "ok: $mod holds the workbench and the module, nothing else was installed under $root"
}
import_with_freecad() {  # freecadcmd imports SagittaCore and _sagitta from the installed folder MOD
  local mod=$1 extra_path=$2
  command -v freecadcmd >/dev/null || { echo "freecadcmd not installed: import check skipped"; return; }
  cat > "$work/import.py" <<PY
import os, sys
if "$extra_path":
    sys.path.insert(0, "$extra_path")
import SagittaCore, _sagitta
ok = all(os.path.dirname(os.path.realpath(m.__file__)) == os.path.realpath("$mod") for m in (SagittaCore, _sagitta))
open("$work/import-result", "w").write("passed" if ok and "uniform" in SagittaCore.SCHEMES else
                                       "wrong modules: %s %s" % (SagittaCore.__file__, _sagitta.__file__))
os._exit(0)
PY
  rm -f "$work/import-result"
  env -u XDG_DATA_HOME HOME="$work/home" timeout 120 freecadcmd "$work/import.py" >/dev/null 2>&1 || true
  [ "$(cat "$work/import-result" 2>/dev/null)" = passed ] || fail "freecadcmd did not import the installed workbench from $mod: $(cat "$work/import-result" 2>/dev/null)"
  echo "ok: freecadcmd imports SagittaCore and _sagitta from $mod"
}

run_steps user
check_mod "$work/home/.local/share/FreeCAD/Mod/Sagitta" "$work/home"
# freecadcmd finds the user Mod folder by itself (no path added).
rm -rf "$work/home/.FreeCAD" "$work/home/.config" "$work/home/.cache"
import_with_freecad "$work/home/.local/share/FreeCAD/Mod/Sagitta" ""
rm -rf "$work/home" && mkdir -p "$work/home"

run_steps package
check_mod "$tree/stage/usr/share/freecad/Mod/Sagitta" "$tree/stage"
import_with_freecad "$tree/stage/usr/share/freecad/Mod/Sagitta" "$tree/stage/usr/share/freecad/Mod/Sagitta"
[ -z "$(find "$work/home" -type f -path '*Mod*' | head -1)" ] || fail "the package steps wrote into the user Mod folder"
echo "test_install.sh: passed"
