"""File → Open / Import of .bpt and .rib Bézier patch files: each patch becomes a Part Bézier face;
a file becomes one Part feature holding the compound of its faces. The file is only read."""
import os

import FreeCAD
import Part

import _sagitta


def patch_face(patch):
    """A Part face on a Part.BezierSurface with the patch's poles (and weights, when rational)."""
    surface = Part.BezierSurface()
    surface.increase(patch["degree_u"], patch["degree_v"])
    columns = patch["degree_v"] + 1
    weights = patch["weights"]
    for k, point in enumerate(patch["points"].tolist()):
        i, j = divmod(k, columns)
        pole = FreeCAD.Vector(*point)
        if weights is None:
            surface.setPole(i + 1, j + 1, pole)
        else:
            surface.setPole(i + 1, j + 1, pole, float(weights[k]))
    return Part.Face(surface)


class PatchFileError(ValueError):
    """A patch file that cannot be imported (unreadable, malformed); the message names the file."""


def add_patches(path, doc):
    """Reads the file (the patch readers' checks apply) and adds one Part::Feature in a transaction.
    Raises PatchFileError, the document unchanged, when the file is rejected."""
    try:
        model = _sagitta.read_model(path)
    except ValueError as error:
        raise PatchFileError(str(error))
    name = os.path.splitext(os.path.basename(path))[0]
    doc.openTransaction("Sagitta import " + name)
    try:
        obj = doc.addObject("Part::Feature", name)
        obj.Shape = Part.makeCompound([patch_face(p) for p in model.patches])
        obj.Label = name
    except Exception as error:
        doc.abortTransaction()
        if doc.getObject(name) is not None:
            doc.removeObject(name)
        raise PatchFileError("%s: %s" % (path, error))
    doc.commitTransaction()
    doc.recompute()
    FreeCAD.Console.PrintMessage("Sagitta import: %s: %d Bézier patches\n" % (path, model.patch_count))
    return obj


def import_file(path, doc):
    """add_patches for File → Open / Import: a rejected file is one report-view line and None."""
    try:
        return add_patches(path, doc)
    except PatchFileError as error:
        FreeCAD.Console.PrintError("Sagitta import: %s\n" % error)
        return None


def load(path, doc=None):
    """The Import command: the file into `doc`, or into a new document named after it when doc is
    None. Raises PatchFileError (no new document left behind) when the file is rejected."""
    if doc is not None:
        return add_patches(path, doc)
    doc = FreeCAD.newDocument(os.path.splitext(os.path.basename(path))[0])
    try:
        return add_patches(path, doc)
    except PatchFileError:
        FreeCAD.closeDocument(doc.Name)
        raise


def open(filename):
    """FreeCAD's File → Open: a new document named after the file."""
    name = os.path.splitext(os.path.basename(filename))[0]
    doc = FreeCAD.newDocument(name)
    import_file(filename, doc)
    return doc


def insert(filename, docname):
    """FreeCAD's File → Import into an existing document."""
    try:
        doc = FreeCAD.getDocument(docname)
    except NameError:
        doc = FreeCAD.newDocument(docname)
    FreeCAD.ActiveDocument = doc
    import_file(filename, doc)
