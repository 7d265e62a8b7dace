#!/usr/bin/env bash
# Runs a FreeCAD test script with a throw-away HOME (no user configuration needed, nothing left
# behind) and passes its exit code on. Usage: run_freecad.sh headless|gui SCRIPT
# Environment: SAGITTA_WORKBENCH_DIR (plugin/freecad), SAGITTA_PYTHON_DIR (the built _sagitta).
# A script passes only when it exits 0 *and* wrote "passed" to $SAGITTA_TEST_RESULT: freecadcmd
# exits 0 after an uncaught exception, so the exit code alone proves nothing.
set -euo pipefail
mode=$1
script=$2
home=$(mktemp -d /tmp/sagitta-freecad-home.XXXXXX)
trap 'rm -rf "$home"' EXIT
export HOME=$home XDG_CONFIG_HOME=$home/.config XDG_DATA_HOME=$home/.local/share XDG_CACHE_HOME=$home/.cache
export SAGITTA_TEST_RESULT=$home/result
finish() {
  local status=$1
  if [ "$status" -eq 0 ] && [ "$(cat "$SAGITTA_TEST_RESULT" 2>/dev/null)" != passed ]; then
    echo "run_freecad.sh: $script did not report 'passed' (it stopped early)" >&2
    status=1
  fi
  exit "$status"
}
if [ "$mode" = headless ]; then
  status=0
  timeout 800 freecadcmd "$script" || status=$?
  finish "$status"
fi
# GUI: install the workbench into the user Mod folder of this HOME, as `cmake --install` would.
mod=$XDG_DATA_HOME/FreeCAD/Mod/Sagitta
mkdir -p "$mod"
cp -r "$SAGITTA_WORKBENCH_DIR"/. "$mod"/
cp "$SAGITTA_PYTHON_DIR"/_sagitta*.so "$mod"/
export QTWEBENGINE_DISABLE_SANDBOX=1 QT_QPA_PLATFORM=xcb LIBGL_ALWAYS_SOFTWARE=1
status=0
timeout 800 xvfb-run -a -s "-screen 0 1400x900x24" freecad "$script" || status=$?
finish "$status"
