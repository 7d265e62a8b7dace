"""GUI test of the Sagitta workbench under Xvfb (run by run_freecad.sh, which installs the workbench
into a throw-away user Mod folder). Activates the workbench, selects faces, runs every command with
FreeCADGui.runCommand, checks what each did, and saves a screenshot (SAGITTA_SCREENSHOT) of the
teapot coloured by certified per-triangle error beside the validation task panel, and one
(SAGITTA_PART_SCREENSHOT) of a plate with holes meshed whole, coloured by certified error. Then issue 18's
acceptance on seven shapes (check_primitives), one screenshot each into SAGITTA_PRIMITIVE_SCREENSHOTS."""
import os
import sys
import time
import traceback

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

failures = []
SHARED = os.environ.get("SHARED_DATA", "")
TEAPOT = os.path.join(SHARED, "teapot.bpt")


def check(condition, what):
    print("%s: %s" % ("ok" if condition else "FAILED", what), flush=True)
    if not condition:
        failures.append(what)


def process_events(rounds=5):
    for _ in range(rounds):
        QtGui.QApplication.processEvents()


class DialogWatcher:
    """Closes the modal message boxes a command opens and records their text."""

    def __init__(self):
        self.texts = []
        self.timer = QtCore.QTimer()
        self.timer.timeout.connect(self.poll)
        self.timer.start(100)

    def poll(self):
        box = QtGui.QApplication.activeModalWidget()
        if isinstance(box, QtGui.QMessageBox):
            self.texts.append(box.text())
            box.done(0)


def save_screenshot(view, path):
    """The main window with the 3D view's own rendering painted in (a window grab misses OpenGL)."""
    mw = FreeCADGui.getMainWindow()
    mw.resize(1280, 760)
    for name in ("Report view", "Python console"):
        dock = mw.findChild(QtGui.QDockWidget, name)
        if dock:
            dock.hide()
    combo = mw.findChild(QtGui.QDockWidget, "Combo View")
    if combo:
        mw.resizeDocks([combo], [430], QtCore.Qt.Horizontal)
    process_events(30)
    view.fitAll()
    mdi = mw.findChild(QtGui.QMdiArea)
    # activeSubWindow() is None while the main window is not the active window (Xvfb gives focus to
    # no one when another client grabs it); the current or only sub-window is the 3D view then.
    sub = mdi.activeSubWindow() or mdi.currentSubWindow() or (mdi.subWindowList() or [None])[0]
    if sub is None:
        return False
    widget = sub.widget()
    origin = widget.mapTo(mw, QtCore.QPoint(0, 0))
    rendering = path + ".view.png"
    view.saveImage(rendering, widget.width(), widget.height(), "White")
    pixmap = mw.grab()
    painter = QtGui.QPainter(pixmap)
    painter.drawImage(origin, QtGui.QImage(rendering))
    painter.end()
    os.unlink(rendering)
    return pixmap.save(path)


def report_view_text():
    """What the Report view shows now, less this test's own ok/FAILED lines."""
    dock = FreeCADGui.getMainWindow().findChild(QtGui.QDockWidget, "Report view")
    edit = dock.findChild(QtGui.QTextEdit) if dock else None
    lines = edit.toPlainText().splitlines() if edit else []
    return "\n".join(line for line in lines if " ok: " not in line and " FAILED: " not in line)


def coloured_fraction(view, path):
    """Fraction of the 3D view's pixels with a saturated colour (the error colours; grey has none)."""
    view.saveImage(path, 320, 240, "White")
    image = QtGui.QImage(path)
    samples = [QtGui.QColor(image.pixel(x, y)) for x in range(0, image.width(), 4) for y in range(0, image.height(), 4)]
    os.unlink(path)
    return sum(1 for c in samples if c.saturation() > 80) / float(len(samples))


def bezier_source(doc):
    import Part
    surface = Part.BezierSurface()
    surface.increase(3, 3)
    for i in range(4):
        for j in range(4):
            surface.setPole(i + 1, j + 1, FreeCAD.Vector(i, j, 0.5 * ((i * j) % 3)))
    face = doc.addObject("Part::Feature", "BezierFace")
    face.Shape = Part.Face(surface)
    return face


def run_command(name, obj=None, sub=None):
    FreeCADGui.Selection.clearSelection()
    if obj is not None:
        FreeCADGui.Selection.addSelection(obj, sub) if sub else FreeCADGui.Selection.addSelection(obj)
    FreeCADGui.runCommand(name)
    process_events(20)


def check_faces_to_check(watcher):
    """Validate of a whole part with a face that cannot be certified (a rational face whose weights lie
    1e70 apart) lists it under "Faces to check" with the reason, and the panel's button selects it on
    the source shape in the 3D view (FreeCAD's name, Face1)."""
    import Part
    import SagittaGui
    doc = FreeCAD.newDocument("FacesToCheck")
    poles = [[FreeCAD.Vector(i, j, 0.3 * ((i - 1) ** 2 - (j - 1) ** 2)) for j in range(3)] for i in range(3)]
    surface = Part.BSplineSurface()
    surface.buildFromPolesMultsKnots(poles, [3, 3], [3, 3], [0.0, 1.0], [0.0, 1.0], False, False, 2, 2,
                                     [[1.0, 1.0, 1.0], [1.0, 1e-70, 1.0], [1.0, 1.0, 1.0]])
    heavy = doc.addObject("Part::Feature", "Heavy")
    heavy.Shape = Part.Shell([Part.Face(surface)])
    doc.recompute()
    run_command("Sagitta_Tessellate", heavy)
    check(SagittaGui.active_panel.accept() is True, "faces to check: Tessellate")
    process_events()
    tess = [o for o in doc.Objects if o.Name != heavy.Name][0]
    run_command("Sagitta_Validate", tess)
    panel = SagittaGui.active_panel
    faces = panel.report.get("faces_to_check", []) if isinstance(panel, SagittaGui.ValidatePanel) else []
    check(len(faces) == 1 and faces[0]["name"] == "Face1" and "weights span" in faces[0]["why"],
          "Validate lists the face that is not certified, with why: %s" % faces)
    button = getattr(panel, "select_button", None)
    check(button is not None and button.isEnabled(), "the panel has a button that selects the faces to check")
    if button is not None:
        button.click()
        process_events()
        selected = [(s.Object.Name, list(s.SubElementNames)) for s in FreeCADGui.Selection.getSelectionEx()]
        check(selected == [("Heavy", ["Face1"])], "the button selects Heavy.Face1 in the 3D view: %s" % selected)
    FreeCADGui.Control.closeDialog()
    FreeCADGui.Selection.clearSelection()
    FreeCAD.closeDocument(doc.Name)


def check_defects(watcher):
    """Issue 18's point 5, as a user meets it, one step each (a step that raises is a failure, the
    next ones still run): Cancel in the creation panel, a refused panel edit, a refused
    property-editor edit, a target error of 0, a refused Validate of a Part object, a malformed .bpt
    through the Import command, the error colours after save and reopen."""
    import Part
    doc = FreeCAD.newDocument("Defects")
    ctx = {"doc": doc, "face": bezier_source(doc), "disk": doc.addObject("Part::Feature", "Disk")}
    # A face on an offset of a B-spline surface (no exact rational form): Validate refuses it. (An
    # offset of a cylinder is a cylinder, and is measured.)
    basis = Part.BSplineSurface()
    basis.interpolate([[FreeCAD.Vector(i, j, 0.3 * (i - 1) * (j - 1)) for j in range(3)] for i in range(3)])
    ctx["disk"].Shape = Part.OffsetSurface(basis, 0.5).toShape()
    doc.recompute()
    for step in (creation_panel_cancel_and_ok, refused_panel_edit, refused_property_edit, fit_target_zero,
                 refused_validate, malformed_import, colours_after_reopen):
        try:
            step(watcher, ctx)
        except Exception:
            traceback.print_exc()
            check(False, "%s raised" % step.__name__)
        FreeCADGui.Control.closeDialog()
    if FreeCAD.listDocuments().get(ctx["doc"].Name) is not None:
        FreeCAD.closeDocument(ctx["doc"].Name)
    process_events(20)


def creation_panel_cancel_and_ok(watcher, ctx):
    import SagittaCore
    import SagittaGui
    doc = ctx["doc"]
    names, undo_count = sorted(o.Name for o in doc.Objects), doc.UndoCount
    run_command("Sagitta_Tessellate", ctx["face"])
    check(isinstance(SagittaGui.active_panel, SagittaGui.TessellatePanel) and len(doc.Objects) == len(names) + 1,
          "Tessellate adds a feature and opens its panel")
    SagittaGui.active_panel.reject()
    process_events()
    check(sorted(o.Name for o in doc.Objects) == names and doc.UndoCount == undo_count,
          "Cancel in the creation panel removes the new feature, no Undo step left (%d)" % (doc.UndoCount - undo_count))
    run_command("Sagitta_Tessellate", ctx["face"])
    SagittaGui.active_panel.level.setValue(3)
    check(SagittaGui.active_panel.accept() is True, "OK in the creation panel keeps the feature")
    tess = [o for o in doc.Objects if SagittaCore.is_tessellation(o)]
    check(len(tess) == 1, "one feature after Cancel then OK")
    name = tess[-1].Name
    doc.undo()
    check(not any(SagittaCore.is_tessellation(o) for o in doc.Objects), "creation + panel edit: one Undo step")
    doc.redo()
    ctx["tess"] = doc.getObject(name)


def refused_panel_edit(watcher, ctx):
    import SagittaCore
    import SagittaGui
    tess = ctx["tess"]
    facets = tess.Mesh.CountFacets
    tess.ViewObject.doubleClicked()
    panel = SagittaGui.active_panel
    panel.scheme.setCurrentIndex(SagittaCore.SCHEMES.index("pn"))
    panel.level.setValue(0)
    seen = len(watcher.texts)
    check(panel.accept() is False, "a refused panel edit keeps the panel open")
    process_events(20)
    texts = watcher.texts[seen:]
    check(len(texts) == 1 and "Level" in texts[0] and "--" not in texts[0], "the refusal names the property: %s" % texts)
    check((tess.Scheme, tess.Level, tess.Mesh.CountFacets) == ("uniform", 3, facets) and "Invalid" not in tess.State,
          "after a refused panel edit the old values and mesh are back, the feature valid (%s)" % tess.State)
    panel.reject()


def refused_property_edit(watcher, ctx):
    tess = ctx["tess"]
    before, threshold = report_view_text(), tess.Threshold
    tess.Threshold = -1.0  # what the property editor does
    tess.Scheme = "esc"
    ctx["doc"].recompute()
    process_events(20)
    added = report_view_text()[len(before):].strip()
    check("Traceback" not in added and "--" not in added and "Threshold" in added and len(added.splitlines()) == 1,
          "a refused property edit: one line in property names (%r)" % added)
    check((tess.Scheme, tess.Threshold) == ("uniform", threshold) and "Invalid" not in tess.State,
          "a refused property edit sets the old values back")


def fit_target_zero(watcher, ctx):
    import SagittaGui
    tess = ctx["tess"]
    run_command("Sagitta_Fit", tess)
    fit = SagittaGui.active_panel
    fit.target.setText("0")
    seen = len(watcher.texts)
    check(fit.accept() is False, "Fit to target 0 is refused")
    process_events(20)
    check(len(watcher.texts) > seen and "> 0" in watcher.texts[-1] and tess.Segments == 0,
          "target 0: a clear message, nothing fitted (%s)" % watcher.texts[seen:])
    fit.reject()


def refused_validate(watcher, ctx):
    doc = ctx["doc"]
    names, seen = sorted(o.Name for o in doc.Objects), len(watcher.texts)
    run_command("Sagitta_Validate", ctx["disk"])
    check(len(watcher.texts) > seen, "Validate of a Part object it cannot certify shows a message")
    check(sorted(o.Name for o in doc.Objects) == names, "a refused Validate leaves no FreeCADMesh object")


def malformed_import(watcher, ctx):
    doc = ctx["doc"]
    bad = os.path.join(os.environ["HOME"], "malformed.bpt")
    with open(bad, "w") as f:
        f.write("1\n3 3\n0 0 0\n")
    QtGui.QFileDialog.getOpenFileName = staticmethod(lambda *args, **kwargs: (bad, ""))
    names, documents = sorted(o.Name for o in doc.Objects), sorted(FreeCAD.listDocuments())
    before, seen = report_view_text(), len(watcher.texts)
    run_command("Sagitta_Import")
    added = report_view_text()[len(before):].strip()
    check(len(watcher.texts) == seen + 1 and "malformed.bpt" in watcher.texts[-1],
          "a malformed .bpt through Import shows a message box (%s)" % watcher.texts[seen:])
    check(len(added.splitlines()) == 1 and "malformed.bpt" in added, "and one report-view line (%r)" % added)
    check(sorted(FreeCAD.listDocuments()) == documents and sorted(o.Name for o in doc.Objects) == names,
          "a malformed .bpt changes nothing")


def colours_after_reopen(watcher, ctx):
    tess = ctx["tess"]
    run_command("Sagitta_Validate", tess)
    FreeCADGui.Control.closeDialog()
    ctx["face"].ViewObject.Visibility = False
    ctx["disk"].ViewObject.Visibility = False
    FreeCADGui.Selection.clearSelection()
    shot = os.path.join(os.environ["HOME"], "colours.png")

    def fraction():
        view = FreeCADGui.ActiveDocument.ActiveView
        view.viewIsometric()
        view.fitAll()
        process_events(20)
        return coloured_fraction(view, shot)
    coloured = fraction()
    check(coloured > 0.05 and tess.ViewObject.Coloring, "Validate colours the mesh (%.3f of the view)" % coloured)
    path = os.path.join(os.environ["HOME"], "defects.FCStd")
    ctx["doc"].saveAs(path)
    FreeCAD.closeDocument(ctx["doc"].Name)
    process_events(20)
    ctx["doc"] = FreeCAD.openDocument(path)
    process_events(20)
    reopened = fraction()
    check(reopened > 0.5 * coloured, "the error colours are back after save + reopen (%.3f)" % reopened)


def press_cancel_after(ms):
    """Clicks the Cancel button of the progress dialog `ms` from now, or as soon after as it shows (a
    loaded machine may show it late; polled every 50 ms for 5 s); the returned dict gets "visible" (a
    dialog was showing) and "cancel" (when it was clicked, perf_counter)."""
    import SagittaGui
    seen = {"tries": 0}

    def press():
        dialog = SagittaGui.active_progress
        seen["visible"] = dialog is not None and dialog.isVisible()
        button = dialog.findChild(QtGui.QPushButton) if dialog is not None else None
        if seen["visible"] and button is not None:
            seen["cancel"] = time.perf_counter()
            button.click()
        elif seen["tries"] < 100:
            seen["tries"] += 1
            QtCore.QTimer.singleShot(50, press)
    QtCore.QTimer.singleShot(ms, press)
    return seen


def check_validate_cancel(watcher, doc, teapot):
    """Validate of the teapot at uniform level 7 (1M triangles: about 1.5 s of certification and
    checks on 2 cores) through the command, cancelled 0.5 s after the start: the command returns
    within 2 s of the Cancel, no
    results stored (the feature's validation properties and colours, the Undo stack), no panel, no
    dialog, one report-view line."""
    import SagittaCore
    import SagittaGui
    faces = ["Face%d" % (k + 1) for k in range(32)]
    big = SagittaCore.make_tessellation(doc, [(teapot, faces)], scheme="uniform", level=7)
    SagittaGui.attach_view_provider(big)
    FreeCADGui.Control.closeDialog()
    keys = ("ErrorLower", "ErrorUpper", "TopologyVerdict", "Certification", "FaceColors", "Triangles")
    values, undo_count, messages = {k: getattr(big, k) for k in keys}, doc.UndoCount, len(watcher.texts)
    before = report_view_text()
    seen = press_cancel_after(500)
    start = time.perf_counter()
    run_command("Sagitta_Validate", big)
    returned = time.perf_counter()
    cancel = seen.get("cancel")
    check(seen.get("visible") and cancel is not None and returned - cancel < 2.0,
          "Validate cancelled %.2f s after the start returned %.2f s after Cancel"
          % ((cancel or start) - start, returned - (cancel or start)))
    added = report_view_text()[len(before):].strip().splitlines()
    check({k: getattr(big, k) for k in keys} == values and doc.UndoCount == undo_count
          and not isinstance(SagittaGui.active_panel, SagittaGui.ValidatePanel) and len(watcher.texts) == messages
          and any("Validate: cancelled" in line for line in added),
          "a cancelled Validate stores nothing (UndoCount %d -> %d, %r)" % (undo_count, doc.UndoCount, added))
    doc.removeObject(big.Name)
    process_events()


def check_fit_cancel(watcher, doc, tess):
    """Issue 18's acceptance: a long fit (the teapot's 32 faces, uniform to 1e-4: about 30 s
    uncancelled) started through the Fit panel; the progress dialog's Cancel pressed within 1 s (a
    QTimer clicks it); a timer tick is processed while the fit runs and within 2 s of the Cancel (the
    GUI is responsive), the fit returns promptly, and the document is unchanged (objects, the
    feature's properties and mesh, no Undo step), with one report-view line "cancelled", no dialog."""
    import SagittaGui
    keys = ("Scheme", "Level", "Segments", "BaseLevel", "Threshold", "TargetError", "Triangles", "ErrorUpper",
            "Certification")
    names, values = sorted(o.Name for o in doc.Objects), {k: getattr(tess, k) for k in keys}
    facets, undo_count, messages = tess.Mesh.CountFacets, doc.UndoCount, len(watcher.texts)
    before = report_view_text()
    run_command("Sagitta_Fit", tess)
    fit = SagittaGui.active_panel
    fit.target.setText("0.0001")
    ticks = []
    ticker = QtCore.QTimer()
    ticker.timeout.connect(lambda: ticks.append(time.perf_counter()))
    ticker.start(50)
    seen = press_cancel_after(700)
    start = time.perf_counter()
    accepted = fit.accept()
    returned = time.perf_counter()
    process_events(5)
    time.sleep(0.1)
    process_events(5)
    ticker.stop()
    cancel = seen.get("cancel")
    check(seen.get("visible") and cancel is not None and cancel - start < 1.0,
          "the fit shows a progress dialog; its Cancel pressed %.2f s after the start"
          % ((cancel or returned) - start))
    check(accepted is False and cancel is not None and returned - cancel < 2.0,
          "Cancel stops the fit: accept returned %.2f s after Cancel" % (returned - (cancel or start)))
    check(any(start + 0.1 < t < (cancel or start) for t in ticks),
          "the GUI processes events while the fit runs (%d timer ticks before Cancel)"
          % sum(1 for t in ticks if t < (cancel or start)))
    # Responsive: the event loop runs on once the cancelled fit has returned, within 2 s of the Cancel.
    after = [t - cancel for t in ticks if cancel is not None and t > returned]
    check(bool(after) and after[0] < 2.0, "a timer tick %.3f s after Cancel, after the fit returned: the GUI is "
          "responsive" % (after[0] if after else -1.0))
    check(sorted(o.Name for o in doc.Objects) == names and {k: getattr(tess, k) for k in keys} == values
          and tess.Mesh.CountFacets == facets and doc.UndoCount == undo_count and "Invalid" not in tess.State,
          "a cancelled fit leaves the document unchanged (UndoCount %d -> %d)" % (undo_count, doc.UndoCount))
    added = report_view_text()[len(before):].strip().splitlines()
    check(len(watcher.texts) == messages and any("Fit: cancelled" in line for line in added),
          "a cancelled fit: one report-view line, no dialog (%r)" % added)
    fit.target.setText("0.02")
    check(fit.accept() is True and tess.Segments == values["Segments"],
          "the next fit runs (the cancellation does not stop it)")
    FreeCADGui.Control.closeDialog()
    deadline = time.perf_counter() + 0.6  # a progress dialog's show timer (0.3 s) must not outlive its work
    while time.perf_counter() < deadline:
        process_events()
        time.sleep(0.02)
    shown = [w for w in QtGui.QApplication.topLevelWidgets() + FreeCADGui.getMainWindow().findChildren(
        QtGui.QProgressDialog) if isinstance(w, QtGui.QProgressDialog) and w.isVisible()]
    check(not shown, "no progress dialog is left showing after the work (%d)" % len(shown))
    FreeCAD.Console.PrintMessage("Sagitta GUI test: fit cancel: Cancel %.2f s after the start, fit returned %.3f s "
                                 "after Cancel, first tick after that %.3f s after Cancel\n"
                                 % ((cancel or start) - start, returned - (cancel or start), after[0] if after else -1))


def check_whole_part(watcher):
    """Tessellate and Validate on a solid with holes through the commands: the whole part is meshed
    (every face, closed), Validate shows each solid's watertightness and the certified distance.
    Saves a screenshot of it (SAGITTA_PART_SCREENSHOT) beside the validation panel."""
    import Part
    import SagittaCore
    import SagittaGui
    FreeCADGui.Control.closeDialog()
    doc = FreeCAD.newDocument("PlateWithHoles")
    plate = Part.makeBox(80, 50, 10).cut(Part.makeCylinder(6, 20, FreeCAD.Vector(20, 25, -5)))
    plate = plate.cut(Part.makeCylinder(4, 10, FreeCAD.Vector(55, 25, 5)))
    source = doc.addObject("Part::Feature", "PlateWithHoles")
    source.Shape = plate
    doc.recompute()
    brep = source.Shape.exportBrepToString()
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(source)
    seen = len(watcher.texts)
    FreeCADGui.runCommand("Sagitta_Tessellate")
    process_events()
    check(len(watcher.texts) == seen, "Tessellate on a solid shows no error")
    SagittaGui.active_panel.level.setValue(3)
    SagittaGui.active_panel.accept()
    process_events()
    tess = [o for o in doc.Objects if SagittaCore.is_tessellation(o)]
    check(len(tess) == 1 and tess[0].WholePart, "Tessellate on a solid meshes the whole part")
    if len(tess) != 1:
        return
    tess = tess[0]
    check(tess.Mesh.countSegments() == len(plate.Faces) and tess.Mesh.isSolid(),
          "whole part: one segment per face (%d), closed" % tess.Mesh.countSegments())
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(tess)
    FreeCADGui.runCommand("Sagitta_Validate")
    process_events()
    panel = SagittaGui.active_panel
    check(isinstance(panel, SagittaGui.ValidatePanel) and panel.report.get("kind") == "part"
          and tess.TopologyVerdict == "solid 1: closed", "Validate on a whole part: %s" % tess.TopologyVerdict)
    check(tess.Certification == "certified" and panel.report["certified"]
          and 0 < tess.ErrorLower <= tess.ErrorUpper < float("inf"),
          "whole part certified: [%g, %g]" % (tess.ErrorLower, tess.ErrorUpper))
    check(source.Shape.exportBrepToString() == brep, "the source shape is unchanged")
    colours = part_colours_by_error(tess, panel)
    source.ViewObject.Visibility = False
    tess.ViewObject.DisplayMode = "Flat Lines"
    FreeCADGui.getMainWindow().statusBar().clearMessage()  # the earlier wrong selections' message
    FreeCADGui.Selection.clearSelection()
    view = FreeCADGui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    shot = os.environ.get("SAGITTA_PART_SCREENSHOT")
    if shot:
        check(save_screenshot(view, shot), "screenshot saved to %s" % shot)
    FreeCADGui.Control.closeDialog()
    part_colours_after_reopen(tess, colours)


def part_colours_by_error(tess, panel):
    """After Validate a whole part is coloured by certified error, as a patch model is: its colours
    are those of the certificate's per-triangle bounds (no longer one per face), the view shows them,
    and the panel has the legend. Returns the colours (rounded)."""
    import SagittaCore
    import SagittaGui
    expected, top = SagittaCore.certified_error_colours(panel.report["triangle_error"].tolist())
    got = [tuple(round(c, 2) for c in colour[:3]) for colour in tess.FaceColors]
    check(len(got) == tess.Mesh.CountFacets and got == [tuple(round(c, 2) for c in e) for e in expected]
          and top == panel.report["colour_scale_top"] > 0,
          "whole part coloured by certified error (scale top %g)" % top)
    check(tess.ViewObject.Coloring and len(panel.form.findChildren(SagittaGui.LegendWidget)) == 1,
          "the part's colours shown, with the legend in the panel")
    return got


def part_colours_after_reopen(tess, colours):
    """The whole part's error colours (`colours`) are stored and shown again after save + reopen."""
    doc = tess.Document
    path, name = os.path.join(os.environ["HOME"], "part-colours.FCStd"), tess.Name
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    process_events(20)
    doc = FreeCAD.openDocument(path)
    process_events(20)
    reopened = doc.getObject(name)
    stored = [tuple(round(c, 2) for c in colour[:3]) for colour in reopened.FaceColors]
    view = FreeCADGui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    process_events(20)
    shown = coloured_fraction(view, os.path.join(os.environ["HOME"], "part-colours.png"))
    check(stored == colours and reopened.ViewObject.Coloring and shown > 0.05,
          "the part's error colours are back after save + reopen (%.3f of the view coloured)" % shown)
    FreeCAD.closeDocument(doc.Name)


def check_memory_refusal(watcher, tess):
    """Issue 18: a level beyond memory, chosen in the panel, is refused before anything is allocated:
    a message saying what it would need and which Level fits, the panel still open, the feature as
    it was (here Maximum memory 256 MiB, the teapot's tessellation at Level 9: 16 million triangles)."""
    import resource
    import SagittaCore
    import SagittaGui
    params = FreeCAD.ParamGet(SagittaCore.PARAM_PATH)
    params.SetInt("MaxMemoryMiB", 256)
    try:
        FreeCADGui.Control.closeDialog()
        before = (tess.Scheme, tess.Level, tess.Segments, tess.Mesh.CountFacets)
        tess.ViewObject.doubleClicked()
        panel = SagittaGui.active_panel
        panel.scheme.setCurrentIndex(SagittaCore.SCHEMES.index("uniform"))
        panel.segments.setValue(0)
        panel.level.setValue(9)
        seen, peak = len(watcher.texts), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        check(panel.accept() is False, "a level beyond memory keeps the panel open")
        process_events(20)
        grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak) / 1024.0
        texts = watcher.texts[seen:]
        check(len(texts) == 1 and "Level 9 would need about" in texts[0] and "choose Level ≤ 6" in texts[0]
              and "--" not in texts[0], "the memory refusal says what fits: %s" % texts)
        check((tess.Scheme, tess.Level, tess.Segments, tess.Mesh.CountFacets) == before
              and "Invalid" not in tess.State and grown < 200,
              "after the refusal the feature is as it was, peak memory grown %.0f MB" % grown)
        panel.reject()
    finally:
        params.RemInt("MaxMemoryMiB")


def primitive_sources(doc):
    """Issue 18's shapes as a new user makes them: Part Box with every edge filleted, Cylinder,
    Sphere, Torus, Cone (default, no apex), a Cut (plate minus a cylinder: a through hole) and a
    PartDesign Body with a Pad and a through-all Pocket. Returns the objects to tessellate."""
    import Part
    from FreeCAD import Vector
    box = doc.addObject("Part::Box", "Box")
    box.Length, box.Width, box.Height = 20, 15, 10
    doc.recompute()
    fillet = doc.addObject("Part::Fillet", "FilletedBox")
    fillet.Base = box
    fillet.Edges = [(k + 1, 2.0, 2.0) for k in range(len(box.Shape.Edges))]
    shapes = [fillet] + [doc.addObject("Part::" + kind, kind) for kind in ("Cylinder", "Sphere", "Torus", "Cone")]
    plate = doc.addObject("Part::Box", "Plate")
    plate.Length, plate.Width, plate.Height = 40, 30, 5
    hole = doc.addObject("Part::Cylinder", "Hole")
    hole.Radius, hole.Height, hole.Placement.Base = 6, 20, Vector(20, 15, -5)
    cut = doc.addObject("Part::Cut", "PlateWithHole")
    cut.Base, cut.Tool = plate, hole
    body = doc.addObject("PartDesign::Body", "Body")
    pad_sketch = body.newObject("Sketcher::SketchObject", "PadSketch")
    pad_sketch.Support, pad_sketch.MapMode = (body.Origin.OriginFeatures[3], [""]), "FlatFace"  # XY_Plane
    corners = [Vector(0, 0, 0), Vector(30, 0, 0), Vector(30, 20, 0), Vector(0, 20, 0)]
    for k in range(4):
        pad_sketch.addGeometry(Part.LineSegment(corners[k], corners[(k + 1) % 4]))
    doc.recompute()
    pad = body.newObject("PartDesign::Pad", "Pad")
    pad.Profile, pad.Length = pad_sketch, 8
    doc.recompute()
    pocket_sketch = body.newObject("Sketcher::SketchObject", "PocketSketch")
    pocket_sketch.Support, pocket_sketch.MapMode = (pad, ["Face6"]), "FlatFace"  # the top face
    pocket_sketch.addGeometry(Part.Circle(Vector(15, 10, 0), Vector(0, 0, 1), 4))
    doc.recompute()
    pocket = body.newObject("PartDesign::Pocket", "Pocket")
    pocket.Profile, pocket.Type = pocket_sketch, 1  # through all
    doc.recompute()
    return shapes + [cut, body]


def open_edge_count(mesh):
    """Edges of a Mesh.Mesh used by exactly one facet, counted from its facet list (not the library's)."""
    uses = {}
    for facet in mesh.Topology[1]:
        for k in range(3):
            edge = tuple(sorted((facet[k], facet[(k + 1) % 3])))
            uses[edge] = uses.get(edge, 0) + 1
    return sum(1 for n in uses.values() if n == 1)


def sampled_mesh_to_shape(mesh, shape, samples=150):
    """The largest distance from a triangle's centroid (up to `samples` triangles, evenly spread) to
    the shape's faces, by OCCT's distToShape: a lower estimate of the mesh -> surface distance, made
    without Sagitta, that a certified upper bound must not be below."""
    import Part
    surface = Part.makeCompound(shape.Faces)  # the faces, not the solid: a point inside is not at 0
    points, facets = mesh.Topology
    step = max(1, len(facets) // samples)
    worst = 0.0
    for a, b, c in facets[::step]:
        centroid = (points[a] + points[b] + points[c]) * (1.0 / 3.0)
        worst = max(worst, surface.distToShape(Part.Vertex(centroid))[0])
    return worst


# (shape, scheme) pairs whose Validate is not certified because of the C++ part certificate, with
# its reason (certificate.faces[].reason of `sagitta validate PART.brep --json`): reported, see
# docs/FREECAD.md. The test checks that exactly these, and only on the faces named, are not certified.
KNOWN_UNCERTIFIED = {}  # (shape, scheme) -> the reason its uncertified faces must give; none left


def check_primitives(watcher, shots):
    """Issue 18's acceptance on each of primitive_sources' shapes, for uniform and ESC, through the
    commands: Tessellate gives a closed mesh (Mesh.isSolid(), no open edge counted from the facets, no
    non-manifold or inconsistently oriented facet), Validate says every solid is "closed" and a
    certified interval (certified, finite upper >= lower), except the KNOWN_UNCERTIFIED pairs, whose
    uncertified faces must carry the reason recorded there. Saves one screenshot per shape and scheme
    into `shots` (a folder; None: none)."""
    import SagittaCore
    import SagittaGui
    FreeCADGui.Control.closeDialog()
    if shots:
        os.makedirs(shots, exist_ok=True)
    doc = FreeCAD.newDocument("Primitives")
    sources = primitive_sources(doc)
    for source in sources:
        check("Invalid" not in source.State and source.Shape.isValid() and len(source.Shape.Solids) == 1,
              "%s: one valid solid" % source.Name)
    for source in sources:
        for scheme in ("uniform", "esc"):
            try:
                check_primitive(watcher, doc, source, scheme, shots)
            except Exception:
                traceback.print_exc()
                check(False, "%s %s raised" % (source.Name, scheme))
            FreeCADGui.Control.closeDialog()
    FreeCAD.closeDocument(doc.Name)
    process_events(20)


def check_primitive(watcher, doc, source, scheme, shots):
    import SagittaCore
    import SagittaGui
    what = "%s %s" % (source.Name, scheme)
    before = [o.Name for o in doc.Objects]
    run_command("Sagitta_Tessellate", source)
    panel = SagittaGui.active_panel
    panel.scheme.setCurrentIndex(SagittaCore.SCHEMES.index(scheme))
    panel.level.setValue(3)
    if scheme == "esc":
        panel.threshold.setValue(0.01)
    check(panel.accept() is True, "%s: Tessellate" % what)
    process_events()
    tess = [o for o in doc.Objects if o.Name not in before and SagittaCore.is_tessellation(o)]
    check(len(tess) == 1 and tess[0].WholePart and tess[0].Scheme == scheme, "%s: one whole-part feature" % what)
    if len(tess) != 1:
        return
    tess = tess[0]
    mesh = tess.Mesh
    opened = open_edge_count(mesh)
    check(mesh.isSolid() and opened == 0 and not mesh.hasNonManifolds() and mesh.countNonUniformOrientedFacets() == 0,
          "%s: closed mesh (isSolid %s, %d open edges, %d facets)" % (what, mesh.isSolid(), opened, mesh.CountFacets))
    run_command("Sagitta_Validate", tess)
    report = SagittaGui.active_panel.report if isinstance(SagittaGui.active_panel, SagittaGui.ValidatePanel) else {}
    check(report.get("kind") == "part" and tess.TopologyVerdict == "solid 1: closed",
          "%s: Validate says closed (%s)" % (what, tess.TopologyVerdict))
    known = KNOWN_UNCERTIFIED.get((source.Name, scheme))
    faces = report.get("face_certificates", [])
    if known is None:
        check(tess.Certification == "certified" and report.get("certified")
              and tess.ErrorLower <= tess.ErrorUpper < float("inf"),
              "%s: certified Hausdorff [%g, %g] (%s)" % (what, tess.ErrorLower, tess.ErrorUpper, tess.Certification))
        sampled = sampled_mesh_to_shape(mesh, source.Shape)
        check(sampled <= tess.ErrorUpper * (1 + 1e-6) + 1e-5,  # + the float mesh's rounding
              "%s: OCCT's distance from sampled centroids %g <= the certified upper bound %g" % (
                  what, sampled, tess.ErrorUpper))
    else:
        failing = [f for f in faces if not f["certified"]]
        check(tess.Certification.startswith("not certified") and tess.ErrorUpper == float("inf") and failing
              and all(f["reason"].startswith(known) and f["name"] in tess.Certification for f in failing),
              "%s: known failure, not certified on %s (%s)" % (what, [f["name"] for f in failing], known))
    check(len(faces) == len(source.Shape.Faces) and all(f["name"] == "Face%d" % (k + 1) for k, f in enumerate(faces)),
          "%s: one certificate per face, FreeCAD's face names" % what)
    if shots:  # the tessellation alone, beside the validation panel
        for obj in doc.Objects:
            obj.ViewObject.Visibility = obj is tess
        tess.ViewObject.DisplayMode = "Flat Lines"
        FreeCADGui.Selection.clearSelection()
        view = FreeCADGui.ActiveDocument.ActiveView
        view.viewIsometric()
        path = os.path.join(shots, "%s-%s.png" % (source.Name, scheme))
        check(save_screenshot(view, path), "screenshot %s" % path)
        tess.ViewObject.Visibility = False



def run():
    FreeCADGui.activateWorkbench("SagittaWorkbench")
    process_events()
    import SagittaCore
    import SagittaGui
    import SagittaImport
    check(FreeCADGui.activeWorkbench().name() == "SagittaWorkbench", "workbench active")
    for name in SagittaGui.COMMANDS:
        check(name in FreeCADGui.listCommands(), "command %s registered" % name)
    watcher = DialogWatcher()
    check_defects(watcher)
    check_faces_to_check(watcher)

    # Import through the command (its file dialog answered with the teapot).
    if not os.path.exists(TEAPOT):
        print("shared data absent: GUI test skipped", flush=True)
        return
    QtGui.QFileDialog.getOpenFileName = staticmethod(lambda *args, **kwargs: (TEAPOT, ""))
    FreeCADGui.runCommand("Sagitta_Import")
    process_events()
    doc = FreeCAD.ActiveDocument
    check(doc is not None and len(doc.Objects) == 1 and len(doc.Objects[0].Shape.Faces) == 32, "Import: teapot, 32 faces")
    teapot = doc.Objects[0]

    # Wrong and empty selections: a message, no change.
    FreeCADGui.Selection.clearSelection()
    before = len(doc.Objects)
    for command in ("Sagitta_Tessellate", "Sagitta_Validate", "Sagitta_Fit"):
        seen = len(watcher.texts)
        FreeCADGui.runCommand(command)
        process_events(20)
        check(len(watcher.texts) > seen, "%s on an empty selection shows a message" % command)
    check(len(doc.Objects) == before, "empty selections changed nothing")

    # Wrong selections: Fit on a Part object; Tessellate on a Mesh object (no faces).
    undo_count = doc.UndoCount
    FreeCADGui.Selection.addSelection(teapot)
    seen = len(watcher.texts)
    FreeCADGui.runCommand("Sagitta_Fit")
    process_events(20)
    check(len(watcher.texts) > seen, "Fit on a Part object shows a message")
    plain_mesh = doc.addObject("Mesh::Feature", "PlainMesh")
    doc.recompute()
    undo_count, before = doc.UndoCount, len(doc.Objects)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(plain_mesh)
    seen = len(watcher.texts)
    FreeCADGui.runCommand("Sagitta_Tessellate")
    process_events(20)
    check(len(watcher.texts) > seen, "Tessellate on a Mesh object shows a message")
    check(len(doc.Objects) == before and doc.UndoCount == undo_count, "wrong selections changed nothing")
    doc.removeObject(plain_mesh.Name)
    FreeCADGui.Selection.clearSelection()

    # Tessellate one selected face.
    FreeCADGui.Selection.addSelection(teapot, "Face1")
    FreeCADGui.runCommand("Sagitta_Tessellate")
    process_events()
    one = [o for o in doc.Objects if SagittaCore.is_tessellation(o)]
    check(len(one) == 1 and one[0].Patches == 1, "Tessellate on Face1: one patch")
    panel = SagittaGui.active_panel
    check(isinstance(panel, SagittaGui.TessellatePanel), "Tessellate opens its task panel")
    check(len(one) == 1 and isinstance(one[0].ViewObject.Proxy, SagittaGui.ViewProviderTessellation)
          and one[0].ViewObject.Lighting == "Two side", "Tessellate gives the feature the workbench's view provider")
    panel.level.setValue(2)
    panel.accept()
    process_events()
    check(one[0].Level == 2 and one[0].Triangles + one[0].DegenerateTriangles == 2 * 4 * 4, "task panel applies the level")
    doc.undo()  # the creation with the panel's parameters: one step
    process_events()
    check(not any(SagittaCore.is_tessellation(o) for o in doc.Objects), "Undo after Tessellate restores the document")

    # Tessellate all 32 faces (a face selection), validate, fit.
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(teapot, ["Face%d" % (k + 1) for k in range(32)])
    FreeCADGui.runCommand("Sagitta_Tessellate")
    process_events()
    SagittaGui.active_panel.level.setValue(4)
    SagittaGui.active_panel.accept()
    tess = [o for o in doc.Objects if SagittaCore.is_tessellation(o)][0]
    check(tess.Patches == 32 and tess.Level == 4, "Tessellate on 32 faces at level 4")

    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(tess)
    FreeCADGui.runCommand("Sagitta_Fit")
    process_events()
    fit = SagittaGui.active_panel
    check(isinstance(fit, SagittaGui.FitPanel), "Fit opens its task panel")
    fit.target.setText("0.02")
    check(fit.accept() is True, "Fit runs")
    check(tess.TargetError == 0.02 and tess.Segments > 0, "Fit to 0.02 sets the segments (%d)" % tess.Segments)
    check_fit_cancel(watcher, doc, tess)
    check_validate_cancel(watcher, doc, teapot)

    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(tess)
    FreeCADGui.runCommand("Sagitta_Validate")
    process_events()
    panel = SagittaGui.active_panel
    check(isinstance(panel, SagittaGui.ValidatePanel), "Validate opens its task panel")
    check(tess.ErrorUpper > 0 and len(tess.FaceColors) == tess.Mesh.CountFacets, "Validate colours every triangle")
    check(tess.ViewObject.Coloring, "colour mode on")
    check(tess.ErrorUpper <= 0.02, "the fitted tessellation meets the target (%g)" % tess.ErrorUpper)
    report_path = os.path.join(os.environ["HOME"], "report.html")
    panel.save_report(report_path)
    check(os.path.exists(report_path) and "Hausdorff" in open(report_path).read(), "HTML report written")

    # Screenshot: teapot hidden, the coloured tessellation beside the task panel.
    teapot.ViewObject.Visibility = False
    FreeCADGui.Selection.clearSelection()
    view = FreeCADGui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    shot = os.environ.get("SAGITTA_SCREENSHOT")
    if shot:
        check(save_screenshot(view, shot), "screenshot saved to %s" % shot)

    # Validate FreeCAD's own mesh of the teapot (MeshPart): a new mesh object, an external certificate.
    FreeCADGui.Control.closeDialog()
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(teapot)
    count = len(doc.Objects)
    FreeCADGui.runCommand("Sagitta_Validate")
    process_events()
    panel = SagittaGui.active_panel
    check(len(doc.Objects) == count + 1 and isinstance(panel, SagittaGui.ValidatePanel)
          and panel.report["method"] == "reference", "Validate of FreeCAD's own mesh (MeshPart)")

    check_whole_part(watcher)
    check_memory_refusal(watcher, tess)
    check_primitives(watcher, os.environ.get("SAGITTA_PRIMITIVE_SCREENSHOTS"))

    # Preferences page: what it saves is what new features start from.
    page = SagittaGui.PreferencesPage()
    page.loadSettings()
    page.scheme.setCurrentIndex(SagittaCore.SCHEMES.index("esc"))
    page.level.setValue(2)
    page.saveSettings()
    prefs = SagittaCore.preferences()
    check(prefs["scheme"] == "esc" and prefs["level"] == 2, "preferences page saves the defaults")
    watcher.timer.stop()


try:
    run()
except Exception:
    traceback.print_exc()
    failures.append("exception")
print("GUI test: %s" % ("FAILED: " + "; ".join(failures) if failures else "passed"), flush=True)
if not failures:
    with open(os.environ["SAGITTA_TEST_RESULT"], "w") as f:
        f.write("passed")
sys.stdout.flush()
os._exit(1 if failures else 0)
