#!/usr/bin/env bash
# Runs a FreeCAD test script with a throw-away HOME (no user configuration needed, nothing left
# behind) and passes its exit code on. Usage: run_freecad.sh headless|gui SCRIPT
# Environment: SAGITTA_WORKBENCH_DIR (plugin/freecad), SAGITTA_PYTHON_DIR (the built _sagitta).
set -euo pipefail
mode=$1
script=$2
home=$(mktemp -d /tmp/sagitta-freecad-home.XXXXXX)
trap 'rm -rf "$home"' EXIT
export HOME=$home XDG_CONFIG_HOME=$home/.config XDG_DATA_HOME=$home/.local/share XDG_CACHE_HOME=$home/.cache
if [ "$mode" = headless ]; then
  exec_status=0
  timeout 900 freecadcmd "$script" || exec_status=$?
  exit "$exec_status"
fi
# GUI: install the workbench into the user Mod folder of this HOME, as `cmake --install` would.
mod=$XDG_DATA_HOME/FreeCAD/Mod/Sagitta
mkdir -p "$mod"
cp -r "$SAGITTA_WORKBENCH_DIR"/. "$mod"/
cp "$SAGITTA_PYTHON_DIR"/_sagitta*.so "$mod"/
export QTWEBENGINE_DISABLE_SANDBOX=1 QT_QPA_PLATFORM=xcb LIBGL_ALWAYS_SOFTWARE=1
status=0
timeout 900 xvfb-run -a -s "-screen 0 1400x900x24" freecad "$script" || status=$?
exit "$status"
