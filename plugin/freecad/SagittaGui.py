"""Sagitta workbench GUI: commands (toolbar, menu, tooltips), task panels, the view provider of the
tessellation feature and the preferences page. Work is done by SagittaCore; this module turns
selections into calls and errors into FreeCAD messages (nothing here lets an exception reach
FreeCAD's event loop)."""
import os
import threading
import time
import traceback

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

import SagittaCore
import SagittaImport
import _sagitta

ICONS = os.path.join(os.path.dirname(__file__), "icons")
active_panel = None  # the open Sagitta task panel (scripts and tests reach it here)
active_progress = None  # the progress dialog of the long work running now (tests press its Cancel)
PROGRESS_AFTER = 0.3  # seconds of work before the progress dialog shows (quick work shows none)


def icon(name):
    return os.path.join(ICONS, name + ".svg")


def report_error(title, error):
    """Shows a problem as a FreeCAD message: the report view always, a dialog in the GUI.
    Unexpected exceptions also leave their traceback in the report view."""
    if isinstance(error, SagittaCore.Cancelled):  # the user's own choice: one line, no dialog
        FreeCAD.Console.PrintMessage("Sagitta %s: cancelled\n" % title)
        return
    expected = isinstance(error, (SagittaCore.SagittaError, SagittaImport.PatchFileError))
    text = str(error) if expected else "%s: %s" % (type(error).__name__, error)
    FreeCAD.Console.PrintError("Sagitta %s: %s\n" % (title, text))
    if not expected:
        FreeCAD.Console.PrintLog(traceback.format_exc())
    if not os.environ.get("SAGITTA_NO_DIALOGS"):
        QtGui.QMessageBox.warning(FreeCADGui.getMainWindow(), "Sagitta " + title, text)


def run_with_progress(title, work):
    """SagittaCore's long-work runner in the GUI: runs work() (C++ work that touches no document
    object) in a worker thread while this thread keeps FreeCAD's event loop running, with a busy
    progress dialog (window-modal: the document cannot be edited meanwhile) whose Cancel asks the C++
    work to stop (_sagitta.request_cancel: it stops at its next budget check). Returns work()'s result
    or raises its exception, here; once cancelled, raises SagittaCore.Cancelled when the worker has
    stopped, whatever it returned, so the caller changes nothing."""
    global active_progress
    if active_progress is not None:  # one run at a time: a second would clear the first one's Cancel
        raise SagittaCore.SagittaError("Another Sagitta computation is running; wait for it or cancel it")
    SagittaCore.start_run()
    outcome = {}

    def worker():
        try:
            outcome["result"] = work()
        except BaseException as error:  # handed to the GUI thread, raised there
            outcome["error"] = error
    dialog = QtGui.QProgressDialog(title + "…", "Cancel", 0, 0, FreeCADGui.getMainWindow())
    dialog.setWindowTitle("Sagitta")
    dialog.setWindowModality(QtCore.Qt.WindowModal)
    dialog.setMinimumDuration(int(PROGRESS_AFTER * 1000))
    dialog.setAutoReset(False)
    dialog.setAutoClose(False)
    cancelled = []

    def cancel():
        if not cancelled:
            cancelled.append(time.perf_counter())
            _sagitta.request_cancel()
            FreeCAD.Console.PrintLog("Sagitta: cancelling %s\n" % title)
    dialog.canceled.connect(cancel)
    thread = threading.Thread(target=worker, name="Sagitta: " + title, daemon=True)
    start = time.perf_counter()
    thread.start()
    active_progress = dialog
    try:
        while thread.is_alive():
            if not dialog.isVisible() and not cancelled and time.perf_counter() - start >= PROGRESS_AFTER:
                dialog.show()
            # While the modal dialog is not showing (the first 0.3 s, after Cancel) user input waits:
            # no command may start meanwhile.
            flags = QtCore.QEventLoop.AllEvents if dialog.isVisible() else QtCore.QEventLoop.ExcludeUserInputEvents
            QtGui.QApplication.processEvents(flags, 50)
            thread.join(0.02)
    finally:
        active_progress = None
        dialog.canceled.disconnect(cancel)
        dialog.reset()  # stops its show timer: a dialog of quick work must never show later
        dialog.hide()
        dialog.setParent(None)  # owned by Python now: deleted on return (no event loop needed)
        SagittaCore.start_run()  # the flag would stop the next synchronous work (a recompute)
    if cancelled:
        raise SagittaCore.Cancelled("%s: cancelled" % title)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]


SagittaCore.set_long_runner(run_with_progress)


def selected_links():
    """[(object, [face names])] of the selection; objects selected whole have an empty name list."""
    links = []
    for sel in FreeCADGui.Selection.getSelectionEx():
        subs = [s for s in sel.SubElementNames if s.startswith("Face")]
        links.append((sel.Object, subs))
    return links


def show_panel(panel):
    global active_panel
    if isinstance(active_panel, TessellatePanel):
        active_panel.release()
    FreeCADGui.Control.closeDialog()
    active_panel = panel
    FreeCADGui.Control.showDialog(panel)


def close_panel():
    global active_panel
    active_panel = None
    FreeCADGui.Control.closeDialog()


class ViewProviderTessellation:
    """Icon and double-click editing of a tessellation feature."""

    def __init__(self, vobj):
        vobj.Proxy = self

    def attach(self, vobj):
        self.Object = vobj.Object

    def getIcon(self):
        return icon("Sagitta_Tessellate")

    def updateData(self, obj, prop):
        """FreeCAD's mesh view reads the per-facet colours when Coloring is switched on, not when they
        change: re-applies them when a recompute gives new ones (a whole part's face colours)."""
        if prop == "FaceColors":
            refresh_colours(obj)

    def finishRestoring(self):
        """A reopened document: the view's Coloring is restored before the colours reach the mesh view,
        which then shows grey; re-applies them once the document is loaded."""
        obj = getattr(self, "Object", None)
        if obj is not None:
            refresh_colours(obj)

    def setEdit(self, vobj, mode=0):
        if mode != 0:
            return None
        show_panel(TessellatePanel(vobj.Object))
        return True

    def unsetEdit(self, vobj, mode=0):
        return None

    def doubleClicked(self, vobj):
        show_panel(TessellatePanel(vobj.Object))
        return True

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None


def refresh_colours(obj):
    """Makes the mesh view show the feature's per-triangle colours (FaceColors) when Coloring is on."""
    vobj = getattr(obj, "ViewObject", None)
    if vobj is not None and vobj.Coloring and len(obj.FaceColors) == obj.Mesh.CountFacets > 0:
        vobj.Coloring = False
        vobj.Coloring = True


def attach_view_provider(obj):
    """Gives a tessellation feature made by SagittaCore.make_tessellation the workbench's view: icon,
    double-click editing, two-sided lighting; a whole part coloured by B-rep face (after Validate: by
    certified error)."""
    ViewProviderTessellation(obj.ViewObject)
    obj.ViewObject.Lighting = "Two side"  # patch files orient their normals either way
    if obj.WholePart:
        obj.ViewObject.Coloring = True


# ---------------------------------------------------------------------------------------------
# Task panels


def _form(title):
    widget = QtGui.QWidget()
    widget.setWindowTitle(title)
    layout = QtGui.QFormLayout(widget)
    return widget, layout


class TessellatePanel:
    """Parameters of a tessellation feature; OK applies them (one Undo step), Cancel leaves it. The
    panel of a feature just created (creating=True) runs inside the creation's open transaction: OK
    commits it with the parameters (one Undo step), Cancel aborts it (no feature)."""

    def __init__(self, obj, creating=False):
        self.obj = obj
        self.creating = creating
        self.form, layout = _form("Sagitta tessellation")
        self.scheme = QtGui.QComboBox()
        self.scheme.addItems(SagittaCore.SCHEMES)
        self.scheme.setCurrentIndex(SagittaCore.SCHEMES.index(obj.Scheme))
        self.level = QtGui.QSpinBox()
        self.level.setRange(0, 12)
        self.level.setValue(obj.Level)
        self.segments = QtGui.QSpinBox()
        self.segments.setRange(0, 4096)
        self.segments.setValue(obj.Segments)
        self.segments.setToolTip("uniform: N segments per side instead of 2^Level (0: use Level)")
        self.base_level = QtGui.QSpinBox()
        self.base_level.setRange(0, 10)
        self.base_level.setValue(obj.BaseLevel)
        self.threshold = QtGui.QDoubleSpinBox()
        self.threshold.setDecimals(6)
        self.threshold.setRange(0.0, 1e6)
        self.threshold.setValue(obj.Threshold)
        self.stats = QtGui.QLabel(self.stats_text())
        layout.addRow("Scheme", self.scheme)
        layout.addRow("Level", self.level)
        layout.addRow("Segments (uniform, 0: 2^Level)", self.segments)
        layout.addRow("Base level (pn)", self.base_level)
        layout.addRow("Threshold (esc)", self.threshold)
        layout.addRow(self.stats)

    def stats_text(self):
        o = self.obj
        text = "%d patches -> %d triangles, %d vertices in %.3f s" % (o.Patches, o.Triangles, o.Vertices, o.TessellationSeconds)
        return text + ("\nWhole part: " + o.PartSummary if o.WholePart else "")

    def accept(self):
        values = {"Scheme": self.scheme.currentText(), "Level": self.level.value(), "Segments": self.segments.value(),
                  "BaseLevel": self.base_level.value(), "Threshold": self.threshold.value()}
        if any(getattr(self.obj, key) != value for key, value in values.items()):
            values["FaceSegments"] = []  # the fit's per-face densities give way to the panel's edit
            values["FaceEdgeTolerances"] = []
            values["FaceGradedSegments"] = []
        try:  # the meshing in a worker thread with a progress dialog and Cancel, then the recompute
            SagittaCore.apply_with_progress(self.obj, values, edit=not self.creating)
        except Exception as error:
            self.stats.setText(self.stats_text())
            report_error("Tessellate", error)
            return False
        self.release()
        close_panel()
        return True

    def reject(self):
        if self.creating:
            self.creating = False
            doc, name = self.obj.Document, self.obj.Name
            doc.abortTransaction()
            if doc.getObject(name) is not None:  # a document without undo keeps it: remove it
                doc.removeObject(name)
            doc.recompute()
        close_panel()
        return True

    def release(self):
        """Commits the creation's transaction (OK, or another panel replacing this one)."""
        if self.creating:
            self.creating = False
            self.obj.Document.commitTransaction()


class LegendWidget(QtGui.QWidget):
    """The colour scale of the per-triangle error, 0 to `top` (model units)."""

    def __init__(self, top):
        super().__init__()
        self.top = top
        self.setMinimumHeight(46)

    def paintEvent(self, event):
        painter = QtGui.QPainter(self)
        width = self.width() - 10
        gradient = QtGui.QLinearGradient(5, 0, 5 + width, 0)
        for k in range(5):
            r, g, b = SagittaCore.legend_colour(k / 4.0)
            gradient.setColorAt(k / 4.0, QtGui.QColor.fromRgbF(r, g, b))
        painter.fillRect(5, 4, width, 18, QtGui.QBrush(gradient))
        for k in range(5):
            x = 5 + width * k / 4.0
            label = "%.2e" % (self.top * k / 4.0)
            painter.drawText(int(x) - (0 if k == 0 else 50 if k == 4 else 25), 40, label)
        painter.end()


def interval_text(interval):
    upper = interval["upper"]
    return "[%.6g, %s]" % (interval["lower"], "%.6g" % upper if upper is not None else "not certified")


class ValidatePanel:
    """Results of a validation: certified intervals, topology verdict, colour legend, HTML report."""

    def __init__(self, label, report, source=None):
        self.label = label
        self.report = report
        self.source = source  # the feature's Source links: faces_to_check are selected there
        self.form, layout = _form("Sagitta validation")
        if report.get("kind") == "part":
            self.part_rows(layout, report)
            self.check_rows(layout, report)
        else:
            self.patch_rows(layout, label, report)
        self.report_button = QtGui.QPushButton("Save HTML report…")
        self.report_button.clicked.connect(self.save_report)
        layout.addRow(self.report_button)

    @staticmethod
    def part_rows(layout, report):
        """A whole part: watertightness per solid; the certified distance, or which faces are not
        certified and why (FreeCAD's face names)."""
        def label(text):
            widget = QtGui.QLabel(text)
            widget.setWordWrap(True)
            return widget
        layout.addRow(label("<b>%s</b>: whole part, %d triangles, %d faces (%d trimmed, %d skipped)" % (
            report["label"], report["triangles"], report["faces"], report["faces_trimmed"], report["faces_skipped"])))
        layout.addRow("Distance", label(report["distance"]))
        layout.addRow("Hausdorff", label(interval_text(report["hausdorff"])))
        ValidatePanel.part_legend_rows(layout, report, label)
        for check in report["solids"]:
            layout.addRow(SagittaCore.solid_name(check), label(SagittaCore.solid_verdict(check)))
            layout.addRow("", label("open edges %d (model boundary %d, cracks %d), T-junctions %d, non-manifold %d" % (
                check["open_edges"], check["model_boundary_edges"], check["crack_edges"], check["t_junctions"],
                check["non_manifold_edges"])))

    def check_rows(self, layout, report):
        """The faces to look at (not certified, skipped, bordered by cracks) with why, and a button that
        selects them on the source shape in the 3D view."""
        faces = report.get("faces_to_check", [])
        if not faces:
            return
        text = QtGui.QLabel("Faces to check: " + "; ".join("%s (%s)" % (f["name"], f["why"]) for f in faces))
        text.setWordWrap(True)
        layout.addRow(text)
        self.select_button = QtGui.QPushButton("Select these %d faces in the 3D view" % len(faces))
        self.select_button.setEnabled(bool(self.source))
        self.select_button.clicked.connect(self.select_faces)
        layout.addRow(self.select_button)

    def select_faces(self):
        """Selects faces_to_check on the source objects (shown, so that the selection is visible)."""
        try:
            elements = SagittaCore.face_elements(self.source)
            FreeCADGui.Selection.clearSelection()
            for f in self.report.get("faces_to_check", []):
                obj, name = elements[f["face_index"]]
                obj.ViewObject.Visibility = True
                FreeCADGui.Selection.addSelection(obj, name)
        except Exception as error:
            report_error("Validate", error)

    @staticmethod
    def part_legend_rows(layout, report, label):
        """The colour scale of a whole part's per-triangle certified error (when a face is certified),
        and the colour of the triangles whose face is not certified (no bound: not on the scale)."""
        uncertified = report.get("uncertified_triangles", 0)
        if uncertified < len(report.get("triangle_error", ())):  # a scale only for bounds there are
            layout.addRow(label("Per-triangle certified error (model units):"))
            layout.addRow(LegendWidget(report.get("colour_scale_top", 0.0)))
        if uncertified:
            r, g, b = (int(255 * c) for c in SagittaCore.UNCERTIFIED_COLOUR)
            layout.addRow(label("<span style='color:#%02x%02x%02x'>&#9632;</span> magenta: %d triangles on faces "
                                "not certified (no bound)" % (r, g, b, uncertified)))

    @staticmethod
    def patch_rows(layout, label, report):
        """A patch model's tessellation: certified intervals, topology, the colour legend."""
        layout.addRow(QtGui.QLabel("<b>%s</b>: %d triangles, %s, %.3f s" % (
            label, report["triangles"], report["method"], report["seconds"])))
        layout.addRow("Hausdorff", QtGui.QLabel(interval_text(report["hausdorff"])))
        layout.addRow("mesh → surface", QtGui.QLabel(interval_text(report["mesh_to_surface"])))
        layout.addRow("surface → mesh", QtGui.QLabel(interval_text(report["surface_to_mesh"])))
        t = report["topology"]
        layout.addRow("Topology", QtGui.QLabel(SagittaCore.verdict_text(report)))
        layout.addRow("Open edges", QtGui.QLabel("%d (model boundary %d, cracks %d)" % (
            t["open_edges"], t["model_boundary_edges"], t["crack_edges"])))
        layout.addRow("T-junctions / non-manifold", QtGui.QLabel("%d / %d" % (t["t_junctions"], t["non_manifold_edges"])))
        if len(report["triangle_error"]):
            layout.addRow(QtGui.QLabel("Per-triangle certified error (model units):"))
            layout.addRow(LegendWidget(report.get("colour_scale_top", 0.0)))
        else:
            layout.addRow(QtGui.QLabel("No per-triangle error: this mesh has no (u, v) on the surface."))

    def save_report(self, path=None):
        """Writes the HTML report to `path`, or where the user chooses."""
        try:
            if not path:
                path, _ = QtGui.QFileDialog.getSaveFileName(FreeCADGui.getMainWindow(), "Save validation report",
                                                            self.label + "-validation.html", "HTML (*.html)")
            if path:
                SagittaCore.write_html_report(self.report, self.label, path)
                FreeCAD.Console.PrintMessage("Sagitta: report written to %s\n" % path)
        except Exception as error:
            report_error("Validate", error)

    def getStandardButtons(self):
        return int(QtGui.QDialogButtonBox.Close)

    def reject(self):
        close_panel()
        return True

    def accept(self):
        return self.reject()


class FitPanel:
    """Asks for the target error; OK runs the fit and sets the feature's level/threshold. The target
    is typed as a number (any precision, nothing clamped); 0, negative or non-finite is refused."""

    def __init__(self, obj):
        self.obj = obj
        self.form, layout = _form("Sagitta fit to target error")
        self.target = QtGui.QLineEdit()
        self.target.setText("%g" % (obj.TargetError if obj.TargetError > 0 else SagittaCore.preferences()["target_error"]))
        self.target.setToolTip("The certified error wanted, in model units (a number > 0, e.g. 0.01 or 1e-4)")
        layout.addRow(QtGui.QLabel("<b>%s</b> (%s scheme)" % (obj.Label, obj.Scheme)))
        layout.addRow("Target error", self.target)
        self.result = QtGui.QLabel("")
        layout.addRow(self.result)

    def accept(self):
        try:
            result = SagittaCore.fit_tessellation(self.obj, self.target_value())  # progress dialog, Cancel
        except Exception as error:
            report_error("Fit", error)
            return False
        FreeCAD.Console.PrintMessage("Sagitta fit: %s: %d triangles, certified error <= %.6g\n" % (
            self.obj.Label, result["triangles"], result["certified_error"]))
        close_panel()
        return True

    def target_value(self):
        """The typed target; SagittaError when it is not a number."""
        text = self.target.text().strip()
        try:
            return float(text)
        except ValueError:
            raise SagittaCore.SagittaError("The target error must be a number > 0 (model units), got %r" % text)

    def reject(self):
        close_panel()
        return True


# ---------------------------------------------------------------------------------------------
# Commands


def _selected_tessellation():
    for sel in FreeCADGui.Selection.getSelection():
        if SagittaCore.is_tessellation(sel):
            return sel
    return None


class TessellateCommand:
    def GetResources(self):
        return {"Pixmap": icon("Sagitta_Tessellate"), "MenuText": "Tessellate",
                "ToolTip": "Tessellate the selected Part objects or faces into a parametric mesh that follows its "
                           "source: a solid or shell (PartDesign Body, STEP part) or faces of one is meshed whole, "
                           "watertight across faces, one mesh segment per face; parameters in the task panel"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None

    def Activated(self):
        try:
            links = [(o, s) for o, s in selected_links() if not SagittaCore.is_tessellation(o)]
            doc = FreeCAD.ActiveDocument
            obj = SagittaCore.make_tessellation(doc, links, commit=False)  # the panel's OK or Cancel ends it
            panel = TessellatePanel(obj, creating=True)
            try:
                attach_view_provider(obj)
                FreeCADGui.Selection.clearSelection()
                FreeCADGui.Selection.addSelection(obj)
            except Exception:
                panel.reject()
                raise
            show_panel(panel)
        except Exception as error:
            report_error("Tessellate", error)


class ValidateCommand:
    def GetResources(self):
        return {"Pixmap": icon("Sagitta_Validate"), "MenuText": "Validate",
                "ToolTip": "Certify the distance between the selected tessellation (or a Mesh plus its Part source, or "
                           "a Part object alone: FreeCAD's own mesh of it) and the exact surface; colours the mesh by "
                           "per-triangle error"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None

    def Activated(self):
        try:
            obj = _selected_tessellation()
            if obj is not None:
                report = SagittaCore.validate_tessellation(obj)
                show_panel(ValidatePanel(obj.Label, report, obj.Source))
                return
            links = selected_links()
            meshes = [o for o, _ in links if o.isDerivedFrom("Mesh::Feature")]
            shapes = [(o, s) for o, s in links if not o.isDerivedFrom("Mesh::Feature")]
            if not shapes:
                raise SagittaCore.SagittaError(
                    "Select a Sagitta tessellation, or a Mesh object and the Part object it approximates, or a Part object")
            if meshes:
                mesh, report = meshes[0], SagittaCore.validate_mesh_object(meshes[0], shapes)
            else:  # FreeCAD's own mesh of the part; not kept when the validation is refused
                mesh, report = SagittaCore.validate_freecad_mesh(FreeCAD.ActiveDocument, shapes)
            # A part's report lists faces to check: the button selects them on the Part object.
            show_panel(ValidatePanel(mesh.Label, report, shapes if report.get("kind") == "part" else None))
        except Exception as error:
            report_error("Validate", error)


class FitCommand:
    def GetResources(self):
        return {"Pixmap": icon("Sagitta_Fit"), "MenuText": "Fit to target error",
                "ToolTip": "Choose the selected tessellation's parameters (uniform segments, esc level and threshold, "
                           "pn levels) so that its certified error is at most a target"}

    def IsActive(self):
        return FreeCAD.ActiveDocument is not None

    def Activated(self):
        try:
            obj = _selected_tessellation()
            if obj is None:
                raise SagittaCore.SagittaError("Select a Sagitta tessellation to fit")
            show_panel(FitPanel(obj))
        except Exception as error:
            report_error("Fit", error)


class ImportCommand:
    def GetResources(self):
        return {"Pixmap": icon("Sagitta_Import"), "MenuText": "Import patches…",
                "ToolTip": "Import a .bpt or .rib Bézier patch file as Part Bézier faces"}

    def IsActive(self):
        return True

    def Activated(self):
        try:
            path, _ = QtGui.QFileDialog.getOpenFileName(FreeCADGui.getMainWindow(), "Import Bézier patches", "",
                                                        "Bézier patches (*.bpt *.rib)")
            if path:
                SagittaImport.load(path, FreeCAD.ActiveDocument)  # raises, changing nothing, on a bad file
                FreeCADGui.SendMsgToActiveView("ViewFit")
        except Exception as error:
            report_error("Import", error)


# ---------------------------------------------------------------------------------------------
# Preferences


class PreferencesPage:
    """Default scheme, level, threshold, target error and validation depth for new features; the
    memory a command may use."""

    def __init__(self, parent=None):
        self.form = QtGui.QWidget(parent)
        self.form.setWindowTitle("Sagitta")
        layout = QtGui.QFormLayout(self.form)
        self.scheme = QtGui.QComboBox()
        self.scheme.addItems(SagittaCore.SCHEMES)
        self.level = QtGui.QSpinBox()
        self.level.setRange(0, 12)
        self.threshold = QtGui.QDoubleSpinBox()
        self.threshold.setDecimals(6)
        self.threshold.setRange(0.0, 1e6)
        self.target = QtGui.QDoubleSpinBox()
        self.target.setDecimals(6)
        self.target.setRange(1e-6, 1e6)
        self.depth = QtGui.QSpinBox()
        self.depth.setRange(0, 10)
        layout.addRow("Default scheme", self.scheme)
        layout.addRow("Default level", self.level)
        layout.addRow("Default esc threshold", self.threshold)
        layout.addRow("Default target error", self.target)
        layout.addRow("Validation depth budget", self.depth)
        self.memory = QtGui.QSpinBox()
        self.memory.setRange(0, 1 << 24)
        self.memory.setSuffix(" MiB")
        self.memory.setSpecialValueText("automatic (%d%% of the available memory)"
                                        % round(100 * SagittaCore.AVAILABLE_SHARE))
        self.memory.setToolTip("Tessellate, Validate and Fit refuse, before starting, work estimated to need more")
        layout.addRow("Maximum memory", self.memory)

    def loadSettings(self):
        p = SagittaCore.preferences()
        self.scheme.setCurrentIndex(SagittaCore.SCHEMES.index(p["scheme"]))
        self.level.setValue(p["level"])
        self.threshold.setValue(p["threshold"])
        self.target.setValue(p["target_error"])
        self.depth.setValue(p["max_depth"])
        self.memory.setValue(p["max_memory_mib"])

    def saveSettings(self):
        p = FreeCAD.ParamGet(SagittaCore.PARAM_PATH)
        p.SetString("DefaultScheme", self.scheme.currentText())
        p.SetInt("DefaultLevel", self.level.value())
        p.SetFloat("DefaultThreshold", self.threshold.value())
        p.SetFloat("DefaultTargetError", self.target.value())
        p.SetInt("MaxDepth", self.depth.value())
        p.SetInt("MaxMemoryMiB", self.memory.value())


COMMANDS = ["Sagitta_Tessellate", "Sagitta_Validate", "Sagitta_Fit", "Sagitta_Import"]


def register():
    """Adds the commands and the preferences page (once)."""
    FreeCADGui.addCommand("Sagitta_Tessellate", TessellateCommand())
    FreeCADGui.addCommand("Sagitta_Validate", ValidateCommand())
    FreeCADGui.addCommand("Sagitta_Fit", FitCommand())
    FreeCADGui.addCommand("Sagitta_Import", ImportCommand())
    FreeCADGui.addPreferencePage(PreferencesPage, "Sagitta")
