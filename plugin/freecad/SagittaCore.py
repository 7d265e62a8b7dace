"""Sagitta in FreeCAD without the GUI: shapes to patch models, the parametric tessellation feature,
validation and fitting. The GUI commands and the headless tests call exactly these functions.

Nothing here modifies a source shape: shapes are read (poles, or their BREP text) and every result
goes into new or Sagitta-owned objects, inside a document transaction so that Undo works.

This module never imports SagittaGui (the GUI imports it, not the reverse): the GUI command gives the
feature that make_tessellation returns its view provider."""
import math
import os
import re
import tempfile
import threading
import time
import types

import FreeCAD
import Mesh
import Part

import _sagitta

# The schemes, as the library names them (the same list and order as the CLI's --scheme).
SCHEMES = list(_sagitta.scheme_names())
PARAM_PATH = "User parameter:BaseApp/Preferences/Mod/Sagitta"


class SagittaError(Exception):
    """A problem the user can act on (bad selection, unsupported face, invalid parameter)."""


class Cancelled(SagittaError):
    """The user cancelled long work: its result was discarded and the document was not changed."""


# ---------------------------------------------------------------------------------------------
# Long C++ work: run through a runner the GUI installs (a worker thread, a progress dialog, Cancel)

_long_runner = None


def set_long_runner(runner):
    """Installs runner(title, work) -> work()'s result for run_long (SagittaGui: a worker thread with a
    progress dialog and Cancel); None: run here, synchronously (headless)."""
    global _long_runner
    _long_runner = runner


def start_run():
    """Clears what an earlier run left in the library's budget (a cancellation request, a time limit),
    keeping the memory limit: called before each long run (a cancelled run leaves its flag set)."""
    limit = _sagitta.max_memory()
    _sagitta.reset_budget()
    _sagitta.set_max_memory(limit)


def run_long(title, work):
    """Runs work(): C++ work that reads and writes no document object (the caller reads the document
    before and changes it after, in its own thread). Through the installed runner when there is one
    and this is the main thread, else here. Returns work()'s result or raises its exception; the
    runner raises Cancelled when the user cancelled."""
    if _long_runner is None or threading.current_thread() is not threading.main_thread():
        start_run()
        return work()
    return _long_runner(title, work)


# The library words its refusals for the command line; the feature's users edit properties.
OPTION_PROPERTIES = {"level": "Level", "segments": "Segments", "threshold": "Threshold", "base-level": "BaseLevel",
                     "target-error": "TargetError", "max-depth": "validation depth budget (preferences)",
                     "max-triangles": "the triangle limit"}


def in_property_words(text):
    """A library message with its command-line options (`--level L`, `--threshold RHO`) named as the
    feature's properties (Level, Threshold), on one line."""
    def name(match):
        return OPTION_PROPERTIES.get(match.group(1), match.group(0))
    text = re.sub(r"--([a-z]+(?:-[a-z]+)*)(?: [A-Z]+\b(?! \+))?", name, str(text))
    return " ".join(text.split())


def preferences():
    """The user's defaults (preferences page), with built-in values where none are set."""
    p = FreeCAD.ParamGet(PARAM_PATH)
    scheme = p.GetString("DefaultScheme", "uniform")
    return {
        "scheme": scheme if scheme in SCHEMES else "uniform",
        "level": p.GetInt("DefaultLevel", 3),
        "threshold": p.GetFloat("DefaultThreshold", 0.01),
        "target_error": p.GetFloat("DefaultTargetError", 0.01),
        "max_depth": p.GetInt("MaxDepth", 8),
        "max_memory_mib": p.GetInt("MaxMemoryMiB", 0),
    }


# ---------------------------------------------------------------------------------------------
# Shapes -> patch models


def source_faces(links):
    """(label, [(face name, face)]) per linked object: the selected faces, or all faces of the shape."""
    if not links:
        raise SagittaError("Nothing to tessellate: the source is empty")
    out = []
    for obj, subs in links:
        shape = getattr(obj, "Shape", None)
        if shape is None or shape.isNull() or not shape.Faces:
            raise SagittaError("%s has no faces to tessellate" % obj.Label)
        names = selected_face_names(subs)
        if names:
            faces = [(n, shape.getElement(n)) for n in names]
        else:
            faces = [("Face%d" % (k + 1), f) for k, f in enumerate(shape.Faces)]
        out.append((obj.Label, faces))
    return out


def selected_face_names(subs):
    """The face names among a selection's sub-elements, each once, in selection order."""
    names = []
    for sub in subs or []:
        if sub.startswith("Face") and sub not in names:
            names.append(sub)
    return names


def freecad_face_names(links):
    """FreeCAD's name of each face Sagitta reads from `links`, in the order the library numbers them
    (face_index): "Face2" as the selection shows it; "Label.Face2" when several objects are linked."""
    groups = source_faces(links)
    qualify = len(groups) > 1
    return [("%s.%s" % (label, name)) if qualify else name for label, faces in groups for name, _ in faces]


def face_note_name(face, names):
    """The FreeCAD name of a library face report (its face_index into `names`)."""
    index = face.get("face_index", -1)
    return names[index] if 0 <= index < len(names) else face["name"]


def shape_model(links, name="selection"):
    """The patch model of the linked shapes/faces and one report line per face, through the OCCT
    adapter: the faces are copied into a compound whose BREP text `read_brep_string` converts,
    exactly as `sagitta tessellate file.brep` does. Raises SagittaError when no face converts."""
    groups = source_faces(links)
    # Copies: putting the document's own faces into a compound would flag their shared OCCT data.
    faces = [f.copy() for _, fs in groups for _, f in fs]
    try:
        cad = _sagitta.read_brep_string(Part.makeCompound(faces).exportBrepToString(), name)
    except ValueError as error:
        raise SagittaError(str(error))
    names = freecad_face_names(links)
    notes = ["%s: %s%s" % (face_note_name(f, names), f["status"], (" (" + f["reason"] + ")") if f["reason"] else "")
             for f in cad["faces"]]
    if cad["model"].patch_count == 0:
        raise SagittaError("%s: no face could be converted: %s" % (name, "; ".join(notes)))
    return cad["model"], notes


def is_part_source(links):
    """True when a linked shape has solids or shells, or a trimmed face: the source is a part (a
    PartDesign Body, a solid, an imported STEP assembly, or faces of one), meshed whole and watertight
    across faces by mesh_part_brep. Loose untrimmed faces (Bézier patches, a compound of faces) keep
    the patch-model path, as `sagitta tessellate` does for such a BREP file."""
    if any(getattr(obj, "Shape", None) is not None and not obj.Shape.isNull()
           and (obj.Shape.Solids or obj.Shape.Shells) for obj, _ in links):
        return True
    # Loose faces are a part too when one is trimmed (the patch path would leave it out): the same
    # rule as the CLI's (_sagitta's read_brep_string: whole_part).
    try:
        faces = [f.copy() for _, fs in source_faces(links) for _, f in fs]
        cad = _sagitta.read_brep_string(Part.makeCompound(faces).exportBrepToString(), "selection")
    except (ValueError, SagittaError):
        return False
    return bool(cad["whole_part"])


def part_brep_text(links):
    """BREP text of the linked shapes as one compound: a whole shape, or only its selected faces.
    Faces are taken from one copy of their shape, so that faces sharing an edge still share it (the
    mesh stays closed across them) and the document's shape is never touched."""
    shapes = []
    for obj, subs in links:
        shape = getattr(obj, "Shape", None)
        if shape is None or shape.isNull() or not shape.Faces:
            raise SagittaError("%s has no faces to tessellate" % obj.Label)
        names = selected_face_names(subs)
        if names:
            copy = shape.copy()
            shapes.append(Part.makeCompound([copy.getElement(n) for n in names]))
        else:
            shapes.append(shape)
    if len(shapes) == 1:
        text = shapes[0].exportBrepToString()
    else:
        text = Part.makeCompound([s.copy() for s in shapes]).exportBrepToString()
    # Free faces (FreeCAD imports an IGES file as a compound of them) are sewn as the CLI sews an
    # IGES file, in their order: one closed mesh where they meet. Any other shape's text is unchanged.
    return _sagitta.sew_free_faces_brep(text, "selection")


def part_parameters(params):
    """The keyword arguments of _sagitta.mesh_part_brep for a feature's scheme parameters."""
    if params["scheme"] == "pn":
        raise SagittaError("pn is a scheme for triangle meshes; tessellate a part with uniform or esc")
    return {k: v for k, v in params.items()
            if k in ("scheme", "level", "segments", "threshold", "edge_tolerance", "face_segments",
                     "face_edge_tolerance", "face_graded_segments")}


def mesh_part(links, name, params):
    """The whole-part mesh of the linked shapes (a _sagitta.PartMesh); library errors become
    SagittaError. A face that cannot be meshed is listed in the result's faces, never dropped."""
    return mesh_part_text(part_brep_text(links), name, params)


def mesh_part_text(text, name, params):
    """mesh_part of BREP text (part_brep_text's): reads no document object, so it can run in a worker."""
    try:
        return _sagitta.mesh_part_brep(text, name, **part_parameters(params))
    except (ValueError, MemoryError) as error:
        raise library_error(error)


def part_face_notes(part, names):
    """One line per B-rep face, named as FreeCAD names it (`names`: freecad_face_names): what became of it."""
    notes = []
    for f in part.faces:
        kind = f["surface_type"] + (", trimmed" if f["trimmed"] else "")
        name = face_note_name(f, names)
        if f["status"] == "tessellated":
            notes.append("%s (%s): tessellated, %d triangles" % (name, kind, f["triangles"]))
        else:
            notes.append("%s (%s): skipped (%s)" % (name, kind, f["reason"]))
    return notes


def part_summary(part):
    closed = sum(1 for s in part.solids if s["closed"])
    return "%d faces (%d trimmed): %d tessellated, %d skipped; %d solids (%d closed); %d B-rep edges" % (
        len(part.faces), part.faces_trimmed, part.faces_tessellated, part.faces_skipped, len(part.solids), closed,
        part.edges)


def model_to_bpt(model):
    """.bpt text of a model, every coordinate at full double precision (repr): the patches Sagitta
    sees in a FreeCAD shape, for reproducing a result with the `sagitta` command."""
    lines = [str(model.patch_count)]
    for p in model.patches:
        lines.append("%d %d" % (p["degree_u"], p["degree_v"]))
        weights = p["weights"]
        for k, point in enumerate(p["points"]):
            values = [repr(float(c)) for c in point]
            if weights is not None:
                values.append(repr(float(weights[k])))
            lines.append(" ".join(values))
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# Memory: an estimate checked before starting

# Peak memory per triangle of the workbench's work, measured (growth of ru_maxrss): Tessellate of
# the teapot into a FreeCAD mesh 780 bytes (levels 7 and 8: 1 and 4 million triangles); Validate 543
# (the mesh re-made and certified) plus the colours; a whole part (a cylinder, 0.6 and 2.4 million
# triangles) 810-833 into a FreeCAD mesh (363 of it the library's), Validate 200-265 more. Rounded up.
BYTES_PER_TRIANGLE = 1024
# Without a preference, the share of the memory available now that one command may use.
AVAILABLE_SHARE = 0.8


def available_memory():
    """Bytes the system can give now without swapping (MemAvailable in /proc/meminfo; else the free
    physical pages); None when the system does not say."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def memory_limit():
    """(bytes one command may use, how that was chosen): the preference "Maximum memory" (MiB) when
    set, else AVAILABLE_SHARE of available_memory(); (None, reason) when neither is known."""
    mib = preferences()["max_memory_mib"]
    if mib > 0:
        return mib * 2.0 ** 20, "the Maximum memory preference"
    available = available_memory()
    if available is None:
        return None, "the available memory is unknown"
    return AVAILABLE_SHARE * available, "%d%% of the memory available now" % round(100 * AVAILABLE_SHARE)


def gib(nbytes):
    """Bytes in GiB (one decimal), or in MiB below 1 GiB."""
    return "%.1f GiB" % (nbytes / 2.0 ** 30) if nbytes >= 2 ** 30 else "%.0f MiB" % (nbytes / 2.0 ** 20)


def estimate_models(links):
    """The patch models whose sizes estimate the work on the linked source: a part (is_part_source)
    its faces' patches and its trimmed faces' whole patches, a patch model itself."""
    try:
        if is_part_source(links):
            cad = _sagitta.read_brep_string(part_brep_text(links), "selection")
            return [cad["model"], cad["trimmed_model"]]
        return [shape_model(links)[0]]
    except ValueError as error:
        raise SagittaError(str(error))


def estimated_triangles(models, params):
    """Triangles the parameters make at most on the models (estimate_models), computed without
    tessellating: the library's estimated_triangles (esc its full pattern, pn its base times the pattern)."""
    keys = ("scheme", "level", "segments", "base_level")
    try:
        return sum(_sagitta.estimated_triangles(m, **{k: v for k, v in params.items() if k in keys})
                   for m in models if m.patch_count)
    except ValueError as error:
        raise SagittaError(str(error))


def parameter_words(params):
    """The parameter a user lowers to shrink the work, and its value: ("Segments", 5000) or ("Level", 10)."""
    return ("Segments", params["segments"]) if "segments" in params else ("Level", params["level"])


def largest_that_fits(models, params, limit, need):
    """The largest value below the current one of the parameter parameter_words names (the others
    kept) whose estimate fits in `limit` bytes (`need`: the current value's); None when none does."""
    key, value = parameter_words(params)
    name = key.lower()
    lowest = 1 if key == "Segments" or params["scheme"] == "pn" else 0
    candidate = value - 1
    if key == "Segments" or params["scheme"] == "pn":  # the estimate grows as N^2: start near the answer
        candidate = min(candidate, int(value * math.sqrt(limit / need)) + 1)
    while candidate >= lowest:
        if estimated_triangles(models, dict(params, **{name: candidate})) * BYTES_PER_TRIANGLE <= limit:
            return candidate
        candidate -= 1
    return None


class MemoryRefused(SagittaError):
    """The work would need more memory than Sagitta may use: refused before anything is allocated."""


def set_library_memory_limit():
    """Hands memory_limit() to the library (set_max_memory): its estimates and allocation sites refuse
    work beyond it (MemoryLimitExceeded). Returns the limit and how it was chosen."""
    limit, source = memory_limit()
    if limit is not None:
        _sagitta.set_max_memory(limit)
    return limit, source


def check_memory(links, params, what="Tessellate"):
    """Refuses (MemoryRefused, before anything is allocated) work whose estimate
    (estimated_triangles x BYTES_PER_TRIANGLE) exceeds memory_limit(), with the largest parameter
    that fits: "Tessellate: Level 10 would need about 64.0 GiB of memory, more than the 18.4 GiB
    available (80% of the memory available now); choose Level <= 8". Also hands the limit to the
    library (set_max_memory), whose estimates and allocation sites then refuse what this missed."""
    limit, source = set_library_memory_limit()
    if limit is None:
        return
    models = estimate_models(links)
    need = estimated_triangles(models, params) * BYTES_PER_TRIANGLE
    if need <= limit:
        return
    key, value = parameter_words(params)
    fits = largest_that_fits(models, params, limit, need)
    advice = ("choose %s ≤ %d" % (key, fits) if fits is not None
              else "select fewer faces or free memory")
    raise MemoryRefused("%s: %s %d would need about %s of memory, more than the %s available (%s); %s" % (
        what, key, value, gib(need), gib(limit), source, advice))


def memory_words(text):
    """A library memory refusal ("... more than --max-memory 4.5 GiB; lower --level or raise
    --max-memory") in the workbench's words."""
    text = re.sub(r"more than --max-memory ([0-9.eE+-]+ GiB)", r"more than the \1 Sagitta may use", str(text))
    text = text.replace(" or --copies", "")
    text = text.replace("raise --max-memory", "free memory (Maximum memory: Sagitta preferences)")
    return in_property_words(text)


def library_error(error):
    """A library exception as SagittaError: a memory refusal (MemoryLimitExceeded) or a failed
    allocation as MemoryRefused in the workbench's words, anything else with the library's message."""
    if isinstance(error, _sagitta.MemoryLimitExceeded):
        return MemoryRefused(memory_words(error))
    if isinstance(error, MemoryError):
        return MemoryRefused("out of memory (%s); lower Level or Segments, or free memory" % (error or "no message"))
    return SagittaError(str(error))


# ---------------------------------------------------------------------------------------------
# The tessellation feature

STAT_PROPERTIES = [
    ("App::PropertyInteger", "Patches", "Bézier patches tessellated"),
    ("App::PropertyInteger", "Triangles", "Triangles emitted"),
    ("App::PropertyInteger", "Vertices", "Vertices emitted"),
    ("App::PropertyInteger", "DegenerateTriangles", "Collapsed triangles, counted but not emitted"),
    ("App::PropertyFloat", "TessellationSeconds", "Time the scheme took"),
    ("App::PropertyStringList", "SourceFaces", "What became of each source face"),
    ("App::PropertyFloat", "ErrorLower", "Certified lower bound of the Hausdorff distance (after Validate)"),
    ("App::PropertyFloat", "ErrorUpper",
     "Certified upper bound of the Hausdorff distance (after Validate); inf when none is certified (see Certification)"),
    ("App::PropertyString", "TopologyVerdict", "Watertightness verdict (after Validate)"),
    ("App::PropertyColorList", "FaceColors",
     "Per-triangle colours: the certified error (after Validate); a whole part's B-rep faces"),
    ("App::PropertyBool", "WholePart", "The source is a part (solids or shells): meshed whole, watertight across faces"),
    ("App::PropertyString", "PartSummary", "Whole part: faces, trimmed faces, solids"),
    ("App::PropertyIntegerList", "TriangleFace", "Whole part: per triangle, the index of its B-rep face (0-based)"),
    ("App::PropertyString", "Certification",
     "certified, not certified (why), or not validated: whether ErrorUpper is a certified bound"),
]


class TessellationFeature:
    """Proxy of a Mesh::FeaturePython whose mesh is the tessellation of its Source faces; recomputes
    when the source or a parameter changes. Statistics are read-only properties."""

    def __init__(self, obj):
        obj.Proxy = self
        self.setup(obj)

    def setup(self, obj):
        """Adds the properties a tessellation feature has (idempotent)."""
        existing = obj.PropertiesList
        def add(kind, name, group, doc):
            if name not in existing:
                obj.addProperty(kind, name, group, doc)
        add("App::PropertyLinkSubList", "Source", "Sagitta", "Part objects or faces to tessellate")
        add("App::PropertyEnumeration", "Scheme", "Sagitta", "uniform, esc (adaptive) or pn (PN triangles)")
        add("App::PropertyInteger", "Level", "Sagitta",
            "uniform: 2^L segments per side; esc: pattern level; pn: segments per edge")
        add("App::PropertyInteger", "BaseLevel", "Sagitta", "pn: the uniform base level it refines")
        add("App::PropertyInteger", "Segments", "Sagitta", "uniform: N segments per side instead of 2^Level when > 0")
        add("App::PropertyFloat", "Threshold", "Sagitta", "esc: distance threshold (model units)")
        add("App::PropertyFloat", "TargetError", "Sagitta", "Fit to target error: the certified error wanted")
        add("App::PropertyFloat", "EdgeTolerance", "Sagitta",
            "Whole parts: B-rep edges are split until their chords lie within this distance of the curve "
            "(model units; 0: the scheme's own density). Set by Fit")
        add("App::PropertyIntegerList", "FaceSegments", "Sagitta",
            "Whole parts, uniform: segments per patch side of each face (Face 1 first), instead of Segments "
            "where > 0. Set by Fit (each face its own density); empty: Segments on every face")
        add("App::PropertyFloatList", "FaceEdgeTolerances", "Sagitta",
            "Whole parts: a tighter edge tolerance for the edges of each face (Face 1 first) where > 0. Set by "
            "Fit on faces whose certified interval the slivers at their trimming curves widened; empty: none")
        add("App::PropertyFloatList", "FaceGradedSegments", "Sagitta",
            "Whole parts, uniform: a real N for the graded grid of each face (Face 1 first) where > 0, at most its "
            "FaceSegments. Set by Fit (a graded face's cells follow N continuously); empty: the integer N")
        if "Scheme" not in existing:
            obj.Scheme = SCHEMES
        for kind, name, doc in STAT_PROPERTIES:
            add(kind, name, "Statistics", doc)
            obj.setEditorMode(name, 1)  # read-only in the property editor
        obj.setEditorMode("FaceColors", 2)  # hidden: shown as colours
        obj.setEditorMode("TriangleFace", 2)  # hidden: one entry per triangle (also the mesh's segments)

    def onDocumentRestored(self, obj):
        self.setup(obj)
        # FreeCAD does not save mesh segments: a whole part's per-face segments come back from TriangleFace.
        if obj.WholePart and obj.Mesh.countSegments() == 0 and len(obj.TriangleFace) == obj.Mesh.CountFacets > 0:
            mesh = obj.Mesh.copy()
            add_face_segments(mesh, obj.TriangleFace)
            obj.Mesh = mesh
        if "Invalid" not in obj.State:
            self.kept = parameter_values(obj)

    def execute(self, obj):
        """Rebuilds the mesh (build). When the library refuses the parameters (an edit in the property
        editor or a panel), the report view gets one line in property names, the last parameters that
        worked are set back and the mesh is theirs: the feature stays valid, its values and mesh agree.
        With no such parameters, or when the source itself fails, the feature is Invalid. The refusal
        is kept in self.error for edit_tessellation."""
        self.error = None
        start_run()  # a cancelled run leaves its flag set: this rebuild is a new run
        try:
            self.build(obj)
        except SagittaError as error:
            self.error = in_property_words(error)
            kept = getattr(self, "kept", None)
            if kept is None or kept == parameter_values(obj):
                raise SagittaError(self.error)
            FreeCAD.Console.PrintError("Sagitta: %s: %s; back to %s\n" % (
                obj.Label, self.error, ", ".join("%s = %s" % (k, kept[k]) for k in PARAMETERS
                                                 if kept[k] != getattr(obj, k))))
            for key in PARAMETERS:
                if getattr(obj, key) != kept[key]:
                    setattr(obj, key, kept[key])
            try:
                self.build(obj)
            except SagittaError as again:  # the source fails now too: Invalid
                self.error = in_property_words(again)
                raise SagittaError(self.error)
        self.kept = parameter_values(obj)

    def build(self, obj):
        """Rebuilds the mesh from the source; clears validation results (they belong to the old mesh).
        A part source (solids or shells) is meshed whole (mesh_part_brep): one mesh segment and one
        TriangleFace entry per B-rep face; other sources go through the patch model."""
        prepared = self.take_prepared(obj)
        if prepared is None:
            check_memory(obj.Source, scheme_parameters(obj))
        if is_part_source(obj.Source):
            part = prepared if prepared is not None else mesh_part(obj.Source, obj.Label, scheme_parameters(obj))
            obj.Mesh = to_freecad_mesh(part.mesh, part.triangle_face)
            obj.Patches = part.model.patch_count
            obj.Triangles = part.mesh.triangle_count
            obj.Vertices = part.mesh.vertex_count
            obj.DegenerateTriangles = part.mesh.degenerate_triangles
            obj.TessellationSeconds = part.seconds
            obj.SourceFaces = part_face_notes(part, freecad_face_names(obj.Source))
            obj.WholePart = True
            obj.PartSummary = part_summary(part)
            obj.TriangleFace = part.triangle_face.tolist()
            obj.FaceColors = face_colours(obj.TriangleFace)
        else:
            model, notes = shape_model(obj.Source, obj.Label)
            mesh, stats = prepared if prepared is not None else tessellate_model(model, scheme_parameters(obj))
            obj.Mesh = to_freecad_mesh(mesh)
            obj.Patches = stats["patches"]
            obj.Triangles = stats["triangles"]
            obj.Vertices = stats["vertices"]
            obj.DegenerateTriangles = stats["degenerate_triangles"]
            obj.TessellationSeconds = stats["seconds"]
            obj.SourceFaces = notes
            obj.WholePart = False
            obj.PartSummary = ""
            obj.TriangleFace = []
            obj.FaceColors = []
        obj.ErrorLower = 0.0
        obj.ErrorUpper = math.inf
        obj.TopologyVerdict = ""
        obj.Certification = NOT_VALIDATED

    def take_prepared(self, obj):
        """The mesh prepare_mesh computed for exactly this source, label and these parameters (a
        PartMesh, or tessellate_model's (mesh, stats)), once: it is dropped either way; else None."""
        prepared, self.prepared = getattr(self, "prepared", None), None
        if prepared is None:
            return None
        try:
            key = mesh_key(obj, scheme_parameters(obj))
        except SagittaError:
            return None
        return prepared[1] if prepared[0] == key else None

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None


def mesh_key(obj, params):
    """What a feature's mesh depends on: its label (messages), its source's BREP text, the parameters."""
    return obj.Label, part_brep_text(obj.Source), sorted(params.items())


def prepare_mesh(obj, values):
    """Computes, through run_long (the GUI: a worker thread, a progress dialog, Cancel), the mesh the
    feature's recompute with `values` (PARAMETERS) will need, and leaves it for that one recompute
    (TessellationFeature.take_prepared). Changes no property. A refusal is left to the recompute,
    which words it in property names; Cancelled (and any other failure) propagates, nothing kept."""
    obj.Proxy.prepared = None
    settings = types.SimpleNamespace(**dict(parameter_values(obj), **{k: v for k, v in values.items() if k in PARAMETERS}))
    label = obj.Label
    try:
        params = scheme_parameters(settings)
        key = mesh_key(obj, params)
        check_memory(obj.Source, params)  # a refusal: before anything is allocated, worded by the recompute
        if is_part_source(obj.Source):
            text = part_brep_text(obj.Source)
            result = run_long("Tessellating %s" % label, lambda: mesh_part_text(text, label, params))
        else:
            model, _ = shape_model(obj.Source, label)
            result = run_long("Tessellating %s" % label, lambda: tessellate_model(model, params))
    except Cancelled:
        raise
    except SagittaError:
        return
    obj.Proxy.prepared = (key, result)


def apply_with_progress(obj, values, edit=True):
    """Tessellate's task panel: the long meshing first (prepare_mesh: cancellable, the document
    untouched), then edit_tessellation (edit=True: one Undo step) or apply_parameters (the creation
    panel, inside the creation's transaction), whose recompute takes the prepared mesh. Nothing
    prepared is left behind."""
    try:
        prepare_mesh(obj, values)
        if edit:
            edit_tessellation(obj, **values)
        else:
            apply_parameters(obj, values)
    finally:
        obj.Proxy.prepared = None


# The parameters a user edits; the fit sets them too.
PARAMETERS = ("Scheme", "Level", "Segments", "BaseLevel", "Threshold", "EdgeTolerance", "FaceSegments",
              "FaceEdgeTolerances", "FaceGradedSegments")
NOT_VALIDATED = "not validated"


def parameter_values(obj):
    return {key: getattr(obj, key) for key in PARAMETERS}


def scheme_parameters(obj):
    """The feature's parameters as keyword arguments of _sagitta.tessellate (the CLI's options).
    Raises SagittaError for a negative Level, Segments or BaseLevel (the library reads -1 as "not
    given", which a property always is)."""
    for key in ("Level", "Segments", "BaseLevel"):
        if getattr(obj, key) < 0:
            raise SagittaError("%s must be >= 0, got %d" % (key, getattr(obj, key)))
    edge_tolerance = getattr(obj, "EdgeTolerance", 0.0)
    if not (edge_tolerance >= 0.0 and math.isfinite(edge_tolerance)):
        raise SagittaError("EdgeTolerance must be a finite number >= 0, got %r" % (edge_tolerance,))
    if obj.Scheme == "uniform" and obj.Segments > 0:
        params = {"scheme": "uniform", "segments": obj.Segments}
    else:
        params = {"scheme": obj.Scheme, "level": obj.Level}
    if obj.Scheme == "esc":
        params["threshold"] = obj.Threshold
    if obj.Scheme == "pn":
        params["base_level"] = obj.BaseLevel
    if edge_tolerance > 0.0:  # whole parts only (part_parameters); patch models have no B-rep edges
        params["edge_tolerance"] = edge_tolerance
    face_segments = list(getattr(obj, "FaceSegments", []))
    if obj.Scheme == "uniform" and face_segments:  # whole parts only, as edge_tolerance
        if any(n < 0 for n in face_segments):
            raise SagittaError("FaceSegments must be >= 0, got %r" % (face_segments,))
        params["face_segments"] = face_segments
    face_edge_tolerance = list(getattr(obj, "FaceEdgeTolerances", []))
    if face_edge_tolerance:  # whole parts only, as edge_tolerance
        if not all(t >= 0.0 and math.isfinite(t) for t in face_edge_tolerance):
            raise SagittaError("FaceEdgeTolerances must be finite numbers >= 0, got %r" % (face_edge_tolerance,))
        params["face_edge_tolerance"] = face_edge_tolerance
    face_graded = list(getattr(obj, "FaceGradedSegments", []))
    if obj.Scheme == "uniform" and face_graded:  # whole parts only, as face_segments
        if not all(n >= 0.0 and math.isfinite(n) for n in face_graded):
            raise SagittaError("FaceGradedSegments must be finite numbers >= 0, got %r" % (face_graded,))
        params["face_graded_segments"] = face_graded
    return params


def tessellate_model(model, params):
    """Runs a scheme; invalid parameters become SagittaError with the library's message."""
    try:
        return _sagitta.tessellate(model, **{k: v for k, v in params.items()
                                             if k not in ("edge_tolerance", "face_segments", "face_edge_tolerance",
                                                          "face_graded_segments")})
    except (ValueError, MemoryError) as error:
        raise library_error(error)


def face_colours(triangle_face):
    """Per triangle, the colour of its face: hues a golden-ratio step apart, so that neighbouring
    faces differ (shows a whole part's per-face groups)."""
    import colorsys
    palette = {}
    for face in triangle_face:
        if face not in palette:
            palette[face] = colorsys.hsv_to_rgb((face * 0.618033988749895) % 1.0, 0.45, 0.95)
    return [palette[face] for face in triangle_face]


def to_freecad_mesh(mesh, triangle_face=None):
    """A Mesh.Mesh with the same vertices and triangles, in the same order; with `triangle_face`
    (per triangle, its face index), one mesh segment per face, in face order (segment k holds the
    triangles of the k-th face that has any)."""
    vectors = [FreeCAD.Vector(*p) for p in mesh.positions.tolist()]
    result = Mesh.Mesh()
    result.addFacets((vectors, [tuple(t) for t in mesh.triangles.tolist()]))
    if triangle_face is not None and len(triangle_face):
        if result.CountFacets != len(triangle_face):
            raise SagittaError("FreeCAD's mesh has %d facets, the tessellation %d triangles"
                               % (result.CountFacets, len(triangle_face)))
        add_face_segments(result, triangle_face.tolist())
    return result


def add_face_segments(mesh, triangle_face):
    """Adds one segment per face to a Mesh.Mesh: segment k holds the facets of the k-th face (in
    face order) that has any."""
    groups = {}
    for t, face in enumerate(triangle_face):
        groups.setdefault(face, []).append(t)
    for face in sorted(groups):
        mesh.addSegment(groups[face])


def is_tessellation(obj):
    return obj is not None and isinstance(getattr(obj, "Proxy", None), TessellationFeature)


def _transaction(doc, title, work, commit=True):
    """Runs work() inside a document transaction: committed when it succeeds (left open with
    commit=False), aborted (the document left as it was) when it raises."""
    doc.openTransaction(title)
    try:
        result = work()
    except Exception:
        doc.abortTransaction()
        raise
    if commit:
        doc.commitTransaction()
    return result


def make_tessellation(doc, links, scheme=None, level=None, threshold=None, base_level=None, target_error=None,
                      commit=True):
    """Creates a tessellation feature of `links` [(object, [sub-element names])] in one transaction
    and recomputes it. Parameters left None come from the preferences. Raises SagittaError (and
    leaves the document unchanged) for an empty selection, unsupported faces or bad parameters, and
    MemoryRefused (check_memory) before anything is added for work beyond the memory Sagitta may use.
    commit=False leaves the transaction open: the caller commits it (the creation panel's OK) or
    aborts it (its Cancel: no feature). The feature has FreeCAD's default mesh view;
    SagittaGui.attach_view_provider adds the workbench's."""
    if not links:
        raise SagittaError("Select Part objects or faces to tessellate")
    prefs = preferences()
    # Refuse unsupported selections before anything is added.
    if is_part_source(links):
        part_parameters({"scheme": scheme or prefs["scheme"]})
        part_brep_text(links)
    else:
        shape_model(links)
    check_memory(links, {"scheme": scheme or prefs["scheme"], "level": prefs["level"] if level is None else level,
                         "base_level": 2 if base_level is None else base_level})

    def work():
        obj = doc.addObject("Mesh::FeaturePython", "Tessellation")
        TessellationFeature(obj)
        obj.Source = [(o, tuple(subs) if subs else "") for o, subs in links]
        obj.Scheme = scheme or prefs["scheme"]
        obj.Level = prefs["level"] if level is None else level
        obj.BaseLevel = 2 if base_level is None else base_level
        obj.Threshold = prefs["threshold"] if threshold is None else threshold
        obj.TargetError = prefs["target_error"] if target_error is None else target_error
        obj.recompute()
        if "Invalid" in obj.State:
            raise SagittaError(getattr(obj.Proxy, "error", None) or "Tessellation failed; see the report view")
        return obj
    return _transaction(doc, "Sagitta tessellate", work, commit)


def edit_tessellation(obj, **values):
    """Sets feature parameters (Scheme, Level, Segments, Threshold, BaseLevel, TargetError) and recomputes, in
    one transaction. When they are refused, the old values and their mesh are back, the feature is not
    left Invalid, and SagittaError says why in property names."""
    try:
        _transaction(obj.Document, "Sagitta edit tessellation", lambda: apply_parameters(obj, values))
    except SagittaError:
        if ("Touched" in obj.State or "Invalid" in obj.State) and obj.recompute():
            obj.purgeTouched()  # the aborted transaction set the values back: their mesh, up to date
        raise


def apply_parameters(obj, values):
    """Sets feature parameters and recomputes, outside any transaction of its own (the creation panel
    edits inside the creation's). On refusal: the old values back, recomputed, SagittaError raised."""
    old = {key: getattr(obj, key) for key in values}
    for key, value in values.items():
        setattr(obj, key, value)
    obj.recompute()
    error = getattr(obj.Proxy, "error", None)
    if "Invalid" in obj.State or error:
        for key, value in old.items():
            if getattr(obj, key) != value:
                setattr(obj, key, value)
        obj.recompute()
        raise SagittaError(error or "Tessellation failed with these parameters; see the report view")


# ---------------------------------------------------------------------------------------------
# Validation

def error_colours(errors, top):
    """Blue (0) -> green -> red (>= top) per triangle: the legend's scale."""
    colours = []
    for e in errors:
        t = 0.0 if top <= 0 else min(1.0, max(0.0, e / top))
        colours.append(legend_colour(t))
    return colours


# A triangle with no certified bound (its face is not certified): a colour outside the error scale.
UNCERTIFIED_COLOUR = (1.0, 0.0, 1.0)  # magenta


def certified_error_colours(errors):
    """(per-triangle colours, scale top): error_colours over the certified (finite) bounds, the
    scale's top their maximum; a triangle without one (inf: its face not certified) UNCERTIFIED_COLOUR."""
    finite = [e for e in errors if math.isfinite(e)]
    top = max(finite) if finite else 0.0
    scale = iter(error_colours(finite, top))
    return [next(scale) if math.isfinite(e) else UNCERTIFIED_COLOUR for e in errors], top


def legend_colour(t):
    """Colour at position t in [0, 1] of the error scale (blue, cyan, green, yellow, red)."""
    stops = [(0.0, 0.0, 1.0), (0.0, 1.0, 1.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.0), (1.0, 0.0, 0.0)]
    x = t * (len(stops) - 1)
    k = min(int(x), len(stops) - 2)
    f = x - k
    return tuple(a + (b - a) * f for a, b in zip(stops[k], stops[k + 1]))


def validate_tessellation(obj, max_depth=None):
    """Certifies a tessellation feature against its exact source (a fresh model of the source, the
    mesh re-made with surface data) and stores the interval, the verdict and per-triangle colours on
    the feature in one transaction. Returns the report (the fields of `sagitta validate --json`)."""
    if not is_tessellation(obj):
        raise SagittaError("%s is not a Sagitta tessellation" % obj.Label)
    check_memory(obj.Source, scheme_parameters(obj), "Validate")
    if obj.WholePart:
        return validate_part(obj, max_depth)
    depth = preferences()["max_depth"] if max_depth is None else max_depth
    model, _ = shape_model(obj.Source, obj.Label)
    params = scheme_parameters(obj)
    report = run_long("Validating %s" % obj.Label,
                      lambda: run_validation(model, tessellate_model(model, params)[0], depth))
    errors = report["triangle_error"]
    report["colour_scale_top"] = float(errors.max()) if len(errors) else 0.0

    def work():
        obj.ErrorLower = report["hausdorff"]["lower"]
        obj.ErrorUpper = certified_upper(report["hausdorff"])
        obj.TopologyVerdict = verdict_text(report)
        obj.Certification = "certified" if report["certified"] else "not certified"
        obj.FaceColors = error_colours(errors.tolist(), report["colour_scale_top"])
        obj.purgeTouched()
    _transaction(obj.Document, "Sagitta validate", work)
    if FreeCAD.GuiUp:
        obj.ViewObject.Coloring = True
    return report


def certified_upper(interval):
    """The interval's upper bound when it is certified, else inf: never below the lower bound, and
    never a number that could be read as a certified error."""
    upper = interval["upper"]
    return upper if upper is not None and interval["upper_certified"] else math.inf


def part_certificate(part, max_depth):
    """The distance certificate of a whole part, face by face, on its mesh (mesh_part's, the feature's):
    the library's certify_part (`sagitta validate PART --json`'s "certificate", plus triangle_error).
    Library errors become SagittaError."""
    try:
        return _sagitta.certify_part(part, max_depth=max_depth)
    except (ValueError, MemoryError) as error:
        raise library_error(error)


def crack_faces(part):
    """Per face index: how many open mesh edges that are not model boundary (cracks: a face not
    meshed, a seam not stitched, a gap between faces) run along the face's triangles."""
    import numpy
    triangles = numpy.asarray(part.mesh.triangles, dtype=numpy.int64)
    if not len(triangles):
        return {}
    edges = numpy.sort(numpy.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    owner = numpy.tile(numpy.arange(len(triangles)), 3)
    _, inverse, counts = numpy.unique(edges, axis=0, return_inverse=True, return_counts=True)
    open_edge = counts[inverse.reshape(-1)] == 1
    boundary = {tuple(sorted(e)) for e in numpy.asarray(part.boundary_edges, dtype=numpy.int64).tolist()}
    faces = numpy.asarray(part.triangle_face)
    out = {}
    for k in numpy.nonzero(open_edge)[0].tolist():
        if tuple(edges[k].tolist()) not in boundary:
            face = int(faces[owner[k]])
            out[face] = out.get(face, 0) + 1
    return out


def faces_to_check(part, certificate, names):
    """The faces a user should look at, with why, FreeCAD's names: skipped or not certified (the
    certificate's reason), or bordered by cracks (crack_faces). [{"name", "face_index", "why"}]."""
    cracks = crack_faces(part)
    out = []
    for face, c in zip(part.faces, certificate["faces"]):
        why = []
        if not c["certified"]:
            why.append(c.get("reason") or "not certified")
        if cracks.get(face["face_index"]):
            why.append("%d crack edges along it" % cracks[face["face_index"]])
        if why:
            out.append({"name": face_note_name(face, names), "face_index": face["face_index"], "why": "; ".join(why)})
    return out


def face_elements(links):
    """Per face index (the library's numbering): (object, "FaceN"), for selecting it in the 3D view."""
    out = []
    for obj, subs in links:
        names = selected_face_names(subs) or ["Face%d" % (k + 1) for k in range(len(obj.Shape.Faces))]
        out.extend((obj, n) for n in names)
    return out


def certificate_text(certificate, part, names):
    """"certified" when every face is; else "not certified (k of n faces): " and each uncertified face,
    FreeCAD's name (`names`: freecad_face_names) and the certificate's reason."""
    if certificate["certified"]:
        return "certified"
    faces = ["%s: %s" % (face_note_name(face, names), c["reason"])
             for face, c in zip(part.faces, certificate["faces"]) if not c["certified"]]
    if not faces and certificate.get("note"):  # every face certified, a foreign mesh's triangle on none
        return "not certified: " + certificate["note"]
    return "not certified (%d of %d faces): %s" % (len(faces), len(part.faces), "; ".join(faces))


def validate_part(obj, max_depth=None):
    """Watertightness of a whole-part feature, per solid (the library's check_solids on the part
    re-meshed exactly as execute did: the mesher is deterministic), and its distance certificate face
    by face (part_certificate, on the same mesh). Stores the verdict, the interval (ErrorUpper inf
    unless every face is certified), Certification and the colours by certified error per triangle
    (certified_error_colours: magenta where a face is not certified) on the feature in one
    transaction, switches the view's Coloring on, and returns
    the report: {"kind": "part", "label", "triangles", "vertices", "faces", "faces_trimmed",
    "faces_skipped", "distance" (Certification's text), "hausdorff" (the part's interval), "certified",
    "face_certificates" ([{name, route, certified, lower, upper, reason}]), "seconds", "solids":
    [check_solids' dict plus "brep_closed", "brep_valid", "brep_volume" (-1: faces outside every solid)],
    "triangle_error" (per triangle, inf where not certified), "colour_scale_top", "uncertified_triangles"}."""
    depth = preferences()["max_depth"] if max_depth is None else max_depth
    label, text, params = obj.Label, part_brep_text(obj.Source), scheme_parameters(obj)

    def measure():  # C++ work only (run_long): the document is read before and written after
        part = mesh_part_text(text, label, params)
        start = time.perf_counter()
        try:
            checks = _sagitta.check_solids(part.mesh, part.triangle_solid, part.boundary_edges)
        except ValueError as error:
            raise SagittaError(str(error))
        return part, checks, part_certificate(part, depth), start
    part, checks, certificate, start = run_long("Validating %s" % label, measure)
    errors = certificate["triangle_error"].tolist()
    if len(errors) != obj.Mesh.CountFacets:
        raise SagittaError("%s: the part meshes to %d triangles now, the feature has %d: recompute it, then Validate"
                           % (obj.Label, len(errors), obj.Mesh.CountFacets))
    colours, top = certified_error_colours(errors)
    report = part_report(obj.Label, part, checks, certificate, freecad_face_names(obj.Source), start)

    def work():
        obj.ErrorLower = report["hausdorff"]["lower"]
        obj.ErrorUpper = certified_upper(report["hausdorff"])
        obj.TopologyVerdict = part_verdict_text(report)
        obj.Certification = report["distance"]
        obj.FaceColors = colours
        obj.purgeTouched()
    _transaction(obj.Document, "Sagitta validate", work)
    if FreeCAD.GuiUp:
        obj.ViewObject.Coloring = True
    return report


def part_report(label, part, checks, certificate, names, start):
    """validate_part's report of a part mesh, its solid checks (with the B-rep's facts added) and its
    certificate; `names`: freecad_face_names."""
    facts = {s["index"]: s for s in part.solids}
    for check in checks:
        solid = facts.get(check["solid"])
        check["brep_closed"] = bool(solid and solid["closed"])
        check["brep_valid"] = bool(solid and solid["valid"])
        check["brep_volume"] = solid["volume"] if solid else 0.0
    errors = certificate["triangle_error"].tolist()
    _, top = certified_error_colours(errors)
    return {"kind": "part", "label": label, "triangles": part.mesh.triangle_count,
            "vertices": part.mesh.vertex_count, "faces": len(part.faces), "faces_trimmed": part.faces_trimmed,
            "faces_skipped": part.faces_skipped, "solids": checks,
            "distance": certificate_text(certificate, part, names),
            "certified": certificate["certified"], "hausdorff": certificate["hausdorff"],
            "face_certificates": [dict(name=face_note_name(face, names), **{k: c.get(k) for k in (
                "route", "certified", "lower", "upper", "reason")})
                for face, c in zip(part.faces, certificate["faces"])],
            "seconds": time.perf_counter() - start,
            "faces_to_check": faces_to_check(part, certificate, names),
            "triangle_error": certificate["triangle_error"], "colour_scale_top": top,
            "uncertified_triangles": sum(1 for e in errors if not math.isfinite(e))}


def solid_name(check):
    return "faces outside solids" if check["solid"] < 0 else "solid %d" % (check["solid"] + 1)


def solid_verdict(check):
    """One solid's watertightness in words."""
    if check["closed"] and not check["t_junctions"]:
        return "closed"
    parts = []
    if check["crack_edges"]:
        parts.append("%d cracks" % check["crack_edges"])
    if check["model_boundary_edges"]:
        parts.append("%d model boundary edges" % check["model_boundary_edges"])
    for key, name in (("t_junctions", "T-junctions"), ("non_manifold_edges", "non-manifold edges"),
                      ("inconsistent_orientation_edges", "inconsistently oriented edges")):
        if check[key]:
            parts.append("%d %s" % (check[key], name))
    return ", ".join(parts) or "open"


def part_verdict_text(report):
    """Per solid: closed, or what opens it; a B-rep solid that is closed and valid but whose mesh is
    not closed is called out as not watertight."""
    lines = []
    for check in report["solids"]:
        verdict = solid_verdict(check)
        if check["brep_closed"] and check["brep_valid"] and verdict != "closed":
            verdict = "NOT watertight: " + verdict
        lines.append("%s: %s" % (solid_name(check), verdict))
    return "; ".join(lines)


def run_validation(model, mesh, max_depth, reference_segments=32):
    try:
        return _sagitta.validate(model, mesh, max_depth=max_depth, reference_segments=reference_segments)
    except (ValueError, MemoryError) as error:
        raise library_error(error)


def validate_mesh_object(mesh_obj, links, max_depth=None):
    """Certifies any Mesh object against the exact shape of `links`: a part (is_part_source: solids,
    shells or trimmed faces) face by face (validate_part_mesh_object); loose untrimmed faces through a
    certified reference tessellation of their patches (no (u, v) needed). Changes nothing in the
    document."""
    depth = preferences()["max_depth"] if max_depth is None else max_depth
    points, facets = mesh_obj.Mesh.Topology
    if not facets:
        raise SagittaError("%s has no triangles" % mesh_obj.Label)
    placement = mesh_obj.Placement
    positions = [tuple(placement.multVec(p)) for p in points]
    mesh = _sagitta.mesh_from_arrays(positions, facets)
    set_library_memory_limit()  # the library's estimates (its reference tessellation, the validation) check it
    if is_part_source(links):
        return validate_part_mesh_object(mesh_obj.Label, mesh, links, depth)
    model = whole_shape_model(links, mesh_obj.Label)
    return run_long("Validating %s" % mesh_obj.Label, lambda: run_validation(model, mesh, depth))


def validate_part_mesh_object(label, mesh, links, depth):
    """A mesh of a whole part (FreeCAD's MeshPart, an imported STL) certified face by face: the library
    finds its vertices on the part's edges and faces and its triangles on the faces
    (mesh_on_part_brep, `sagitta validate PART --mesh`), then certifies every face as it certifies
    Sagitta's own part meshes. Returns part_report's dict ("kind": "part")."""
    text = part_brep_text(links)

    def measure():  # C++ work only (run_long)
        try:
            part = _sagitta.mesh_on_part_brep(text, label, mesh)
            start = time.perf_counter()
            checks = _sagitta.check_solids(part.mesh, part.triangle_solid, part.boundary_edges)
        except (ValueError, MemoryError) as error:
            raise library_error(error)
        return part, checks, part_certificate(part, depth), start
    part, checks, certificate, start = run_long("Validating %s" % label, measure)
    report = part_report(label, part, checks, certificate, freecad_face_names(links), start)
    report["unassigned_triangles"] = part.unassigned_triangles
    return report


def whole_shape_model(links, name):
    """The patch model of every face of `links`, for measuring a mesh that is not Sagitta's against the
    whole part. Raises SagittaError naming each face that cannot be measured (FreeCAD's names: trimmed
    faces, surfaces with no exact Bézier form) and why: a distance to the other faces alone would be a
    number about part of the part."""
    faces = [f.copy() for _, fs in source_faces(links) for _, f in fs]
    try:
        cad = _sagitta.read_brep_string(Part.makeCompound(faces).exportBrepToString(), name)
    except ValueError as error:
        raise SagittaError(str(error))
    names = freecad_face_names(links)
    missing = ["%s (%s)" % (face_note_name(f, names), f["reason"] or f["status"])
               for f in cad["faces"] if f["status"] != "tessellated"]
    if missing:
        parts = ", ".join(obj.Label for obj, _ in links)
        raise SagittaError(
            "%s cannot be measured against the whole of %s: %d of %d faces have no exact patch model: %s. "
            "Tessellate %s with Sagitta (meshed whole) and Validate that tessellation instead"
            % (name, parts, len(missing), len(cad["faces"]), "; ".join(missing), parts))
    return cad["model"]


def freecad_mesh_of(doc, links, linear_deflection=0.1, angular_deflection=0.5):
    """FreeCAD's own tessellation (MeshPart) of the linked shapes as a new Mesh feature, in a
    transaction: what Validate compares with ours."""
    return _transaction(doc, "Sagitta FreeCAD mesh",
                        lambda: _add_freecad_mesh(doc, links, linear_deflection, angular_deflection))


def _add_freecad_mesh(doc, links, linear_deflection, angular_deflection):
    import MeshPart
    shapes = [o.Shape if not subs else Part.makeCompound([o.Shape.getElement(s) for s in subs]) for o, subs in links]
    obj = doc.addObject("Mesh::Feature", "FreeCADMesh")
    obj.Mesh = MeshPart.meshFromShape(Shape=Part.makeCompound(shapes), LinearDeflection=linear_deflection,
                                      AngularDeflection=angular_deflection, Relative=False)
    obj.recompute()
    return obj


def validate_freecad_mesh(doc, links, max_depth=None, linear_deflection=0.1, angular_deflection=0.5):
    """Validate of a Part object alone: FreeCAD's own mesh of it (freecad_mesh_of) certified against
    it, in one transaction. Returns (mesh object, report); when the validation is refused the mesh is
    not kept (the document is left as it was) and SagittaError says why."""
    def work():
        mesh_obj = _add_freecad_mesh(doc, links, linear_deflection, angular_deflection)
        try:
            return mesh_obj, validate_mesh_object(mesh_obj, links, max_depth)
        except Exception:
            doc.removeObject(mesh_obj.Name)  # also without undo (the abort then restores nothing)
            raise
    return _transaction(doc, "Sagitta validate FreeCAD mesh", work)


def verdict_text(report):
    t = report["topology"]
    if t["watertight"]:
        return "watertight (%d model boundary edges)" % t["model_boundary_edges"]
    return "not watertight: %d cracks, %d T-junctions, %d non-manifold edges" % (
        t["crack_edges"], t["t_junctions"], t["non_manifold_edges"])


def write_html_report(report, label, path):
    """A small self-contained HTML page with the certified intervals and the topology counts,
    written atomically (temporary file in the same folder, then renamed)."""
    import html

    def row(name, interval):
        upper = interval["upper"]
        return "<tr><td>%s</td><td>%.6g</td><td>%s</td><td>%s</td></tr>" % (
            name, interval["lower"], "%.6g" % upper if upper is not None else "not certified",
            "yes" if interval["upper_certified"] else "no")
    if report.get("kind") == "part":
        _write_atomically(path, part_html(report, label))
        return
    t = report["topology"]
    body = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Sagitta validation: %s</title></head><body>" % html.escape(label),
        "<h1>Sagitta validation: %s</h1>" % html.escape(label),
        "<p>%d triangles, %d vertices, %d patches; method %s; %.3f s</p>" % (
            report["triangles"], report["vertices"], report["patches"], report["method"], report["seconds"]),
        "<h2>Certified distance (lower &le; true &le; upper)</h2><table border='1'>",
        "<tr><th>direction</th><th>lower</th><th>upper</th><th>upper certified</th></tr>",
        row("Hausdorff (symmetric)", report["hausdorff"]), row("mesh &rarr; surface", report["mesh_to_surface"]),
        row("surface &rarr; mesh", report["surface_to_mesh"]), "</table>",
        "<h2>Topology: %s</h2><table border='1'>" % html.escape(verdict_text(report)),
    ]
    for key in ("edges", "open_edges", "model_boundary_edges", "crack_edges", "t_junctions", "non_manifold_edges",
                "inconsistent_orientation_edges", "degenerate_triangles", "duplicated_faces"):
        body.append("<tr><td>%s</td><td>%d</td></tr>" % (key.replace("_", " "), t[key]))
    body.append("</table></body></html>\n")
    _write_atomically(path, "\n".join(body))


def interval_words(interval):
    """[lower, upper], the upper bound only when certified."""
    upper = interval["upper"]
    return "[%.6g, %s]" % (interval["lower"], "%.6g" % upper if upper is not None and interval["upper_certified"]
                           else "not certified")


def part_html(report, label):
    """The HTML page of a whole part's validation: per solid counts; the certified distance and each
    face's certificate (FreeCAD's face names)."""
    import html
    keys = ("triangles", "open_edges", "model_boundary_edges", "crack_edges", "t_junctions", "non_manifold_edges",
            "inconsistent_orientation_edges", "euler_characteristic", "signed_volume", "brep_volume")
    body = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Sagitta validation: %s</title></head><body>" % html.escape(label),
        "<h1>Sagitta validation: %s</h1>" % html.escape(label),
        "<p>Whole part: %d triangles, %d vertices, %d faces (%d trimmed, %d skipped)</p>" % (
            report["triangles"], report["vertices"], report["faces"], report["faces_trimmed"], report["faces_skipped"]),
        "<h2>Distance: %s</h2>" % html.escape(report["distance"]),
        "<p>Hausdorff %s</p>" % html.escape(interval_words(report["hausdorff"])),
    ]
    check = report.get("faces_to_check", [])
    body.append("<h2>Faces to check: %s</h2>" % ("none" if not check else "%d" % len(check)))
    if check:
        body.append("<ul>%s</ul>" % "".join("<li>%s: %s</li>" % (html.escape(f["name"]), html.escape(f["why"]))
                                            for f in check))
    body.append("<table border='1'><tr><th>face</th><th>route</th><th>lower</th><th>upper</th><th>reason</th></tr>")
    for f in report["face_certificates"]:
        body.append("<tr><td>%s</td><td>%s</td><td>%.6g</td><td>%s</td><td>%s</td></tr>" % (
            html.escape(f["name"]), html.escape(f["route"] or ""), f["lower"] or 0.0,
            "%.6g" % f["upper"] if f["certified"] else "not certified", html.escape(f["reason"] or "")))
    body += [
        "</table>",
        "<h2>Watertightness per solid</h2><table border='1'><tr><th>solid</th><th>verdict</th>%s</tr>"
        % "".join("<th>%s</th>" % k.replace("_", " ") for k in keys),
    ]
    for check in report["solids"]:
        body.append("<tr><td>%s</td><td>%s</td>%s</tr>" % (
            solid_name(check), html.escape(solid_verdict(check)), "".join("<td>%.6g</td>" % check[k] for k in keys)))
    body.append("</table></body></html>\n")
    return "\n".join(body)


def _write_atomically(path, text):
    """Writes text to path through a temporary file in the same folder, then renames it."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".sagitta-report-")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ---------------------------------------------------------------------------------------------
# Fitting

def check_target_error(target_error):
    """Raises SagittaError unless the target is a finite number > 0 (no clamping: 0 is refused)."""
    if not (isinstance(target_error, (int, float)) and math.isfinite(target_error) and target_error > 0):
        raise SagittaError("The target error must be a finite number > 0 (model units), got %r" % (target_error,))


def fit_part_tessellation(obj, target_error):
    """A whole part's fit (`sagitta fit PART`, docs/FITTING.md): uniform segments per patch side on
    each face and an edge tolerance, the fewest triangles whose certified error (every face) is <=
    target. Sets Scheme uniform, Segments (the largest face's), FaceSegments, FaceGradedSegments,
    EdgeTolerance, FaceEdgeTolerances and TargetError in one transaction; the recompute's mesh is the one the fit certified (the mesher is
    deterministic). SagittaError, nothing changed, when not met."""
    text, label = part_brep_text(obj.Source), obj.Label
    depth = preferences()["max_depth"]
    set_library_memory_limit()

    def fit():  # C++ work only (run_long)
        try:
            return _sagitta.fit_part_brep(text, label, target_error, max_depth=depth)
        except (ValueError, MemoryError) as error:
            raise library_error(error)
    result = run_long("Fitting %s to %g" % (label, target_error), fit)
    if not result["met"]:
        raise SagittaError("%s: the whole part did not meet the target %g: %s" % (label, target_error, result["reason"]))
    edit_tessellation(obj, Scheme="uniform", Segments=result["segments"], EdgeTolerance=result["edge_tolerance"],
                      FaceSegments=result.get("face_segments", []),
                      FaceEdgeTolerances=result.get("face_edge_tolerance", []),
                      FaceGradedSegments=result.get("face_graded_segments", []), TargetError=target_error)
    result["scheme"] = "uniform"
    return result


def fit_parameters_text(result):
    """The parameters a fit result chose, in property names."""
    if result["scheme"] == "uniform":
        return "Segments = %d" % result["segments"]
    if result["scheme"] == "esc":
        return "Level = %d, Threshold = %g" % (result["level"], result["threshold"])
    return "Level = %d, BaseLevel = %d" % (result["level"], result["base_level"])


def fit_tessellation(obj, target_error):
    """Fits the feature's scheme to a certified target error with the library's fit (`sagitta fit`)
    and sets the chosen parameters (uniform: Segments; esc: Level and Threshold; pn: Level and
    BaseLevel) and TargetError in one transaction. Returns the fit report (the fields of `sagitta
    fit --json`). Raises SagittaError, changing nothing, when the target cannot be met."""
    if not is_tessellation(obj):
        raise SagittaError("%s is not a Sagitta tessellation" % obj.Label)
    check_target_error(target_error)
    if obj.WholePart:
        return fit_part_tessellation(obj, target_error)
    model, _ = shape_model(obj.Source, obj.Label)
    scheme = obj.Scheme
    set_library_memory_limit()  # the fit's sizes are bounded; its tessellations check this limit as they allocate

    def fit():  # C++ work only (run_long): the document is changed after it, by edit_tessellation
        try:
            return _sagitta.fit(model, scheme, target_error)
        except (ValueError, MemoryError) as error:
            raise library_error(error)
    result = run_long("Fitting %s to %g" % (obj.Label, target_error), fit)
    if not result["met"]:
        # The fit's last parameters, not a best possible error: finer ones may do better.
        raise SagittaError("The %s scheme did not meet the target %g: the fit stopped at %s (%d triangles), "
                           "certified error %.6g" % (obj.Scheme, target_error, fit_parameters_text(result),
                                                     result["triangles"], result["certified_error"]))
    values = {"TargetError": target_error}
    if obj.Scheme == "uniform":
        values["Segments"] = result["segments"]
    else:
        values["Level"] = result["level"]
        if obj.Scheme == "esc":
            values["Threshold"] = result["threshold"]
        else:
            values["BaseLevel"] = result["base_level"]
    edit_tessellation(obj, **values)
    return result
