# Installs the FreeCAD workbench (component freecad of `cmake --install`): plugin/freecad's Python
# files and icons, and the _sagitta module beside them. Set by plugin/CMakeLists.txt's install(CODE):
# SAGITTA_FREECAD_MOD_DIR (configured folder, may be empty), SAGITTA_WORKBENCH_SOURCE, SAGITTA_MODULE.
#
# Where it goes, first match:
#   1. SAGITTA_FREECAD_MOD_DIR, when configured;
#   2. <prefix>/share/freecad/Mod/Sagitta when the prefix is not the default /usr/local (configured with
#      -DCMAKE_INSTALL_PREFIX or given to `cmake --install --prefix`) or DESTDIR is set: a package
#      (`--prefix /usr` is /usr/share/freecad/Mod, which Debian's FreeCAD reads);
#   3. otherwise the user's Mod folder, the one FreeCAD 0.20 reads: $XDG_DATA_HOME/FreeCAD/Mod/Sagitta,
#      or ~/.local/share/FreeCAD/Mod/Sagitta (FreeCAD does not read /usr/local/share/freecad/Mod).
if(SAGITTA_FREECAD_MOD_DIR)
  set(sagitta_mod_dir "${SAGITTA_FREECAD_MOD_DIR}")
elseif(NOT CMAKE_INSTALL_PREFIX STREQUAL "/usr/local" OR NOT "$ENV{DESTDIR}" STREQUAL "")
  set(sagitta_mod_dir "${CMAKE_INSTALL_PREFIX}/share/freecad/Mod/Sagitta")
elseif(NOT "$ENV{XDG_DATA_HOME}" STREQUAL "")
  set(sagitta_mod_dir "$ENV{XDG_DATA_HOME}/FreeCAD/Mod/Sagitta")
else()
  set(sagitta_mod_dir "$ENV{HOME}/.local/share/FreeCAD/Mod/Sagitta")
endif()
# file(INSTALL) puts DESTDIR in front and records the files in install_manifest.txt.
file(INSTALL "${SAGITTA_WORKBENCH_SOURCE}/" DESTINATION "${sagitta_mod_dir}"
     FILES_MATCHING PATTERN "*.py" PATTERN "*.svg" PATTERN "__pycache__" EXCLUDE)
file(INSTALL "${SAGITTA_MODULE}" DESTINATION "${sagitta_mod_dir}" TYPE MODULE)
