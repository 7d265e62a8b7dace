"""Brute-force check of a certified part mesh, independent of Sagitta's code (docs/CAD.md, "A second batch").

Usage: BF_SHAPE=PART.step BF_MESH=MESH.ply BF_UPPER=E [BF_JSON=CERT.json] freecadcmd tests/bench/unseen_brute_force.py
MESH is a binary PLY as `sagitta fit ... --out` writes it (double x y z, triangles, a patch per face),
read in double. Mesh -> shape: up to 4,000 mesh points (vertices, centroids, edge midpoints), each
with the smaller of OCCT's distToShape to the shape's faces (not its solids: a point inside a solid
is 0 from it) and its distance to its projection onto each face's surface where that projection
lies in the face's domain (both are distances to points of the shape, so at least the true
distance). Shape -> mesh: about 3,000 points of the faces (a staggered (u, v) grid, kept where
isPartOfDomain) against every triangle (exact point-triangle distance). Prints the two maxima and OK
when neither exceeds E, else FALSE CERTIFICATE.

With BF_JSON (the JSON of `sagitta fit --json` or `sagitta validate --json` on the same mesh) the
certified lower bounds of the faces with the largest ones (BF_WITNESS_FACES, default 8) are checked
too, at their witnesses (each face against its own triangles, as the part's interval is defined): the
mesh -> face witness (a mesh point) must be at least the bound from the face, the face -> mesh
witness (a point of the face) at least the bound from the face's triangles; else FALSE LOWER BOUND."""
import os
import random
import struct
import numpy as np
import FreeCAD as App, Part
V = App.Vector
shape = Part.read(os.environ["BF_SHAPE"])
faces = Part.makeCompound(shape.Faces)
upper = float(os.environ["BF_UPPER"])
# Sagitta's binary PLY read in double (FreeCAD's Mesh keeps float32: 0.004 steps at 1e5).
data = open(os.environ["BF_MESH"], 'rb').read()
head = data[:data.index(b'end_header\n')].decode().split('\n')
nv = int([l for l in head if l.startswith('element vertex')][0].split()[2])
nf = int([l for l in head if l.startswith('element face')][0].split()[2])
assert 'property double x' in head and 'property uint patch' in head
h = data.index(b'end_header\n') + len(b'end_header\n')
P = np.frombuffer(data[h:h + 24 * nv], dtype='<f8').reshape(nv, 3).copy()
off = h + 24 * nv; T = []
for i in range(nf):
    assert data[off] == 3
    T.append(struct.unpack_from('<3I', data, off + 1)); off += 17
T = np.array(T)
A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
random.seed(1)
# mesh -> shape: vertices, centroids, edge midpoints
samples = list(P) + list((A + B + C) / 3) + list((A + B) / 2)
if len(samples) > 4000: samples = random.sample(samples, 4000)
def distance_to_faces(p, which=None):
    """At least the distance from p to the faces `which` (the shape's, by default): a distance to some
    of their points."""
    d = (faces if which is None else Part.makeCompound(which)).distToShape(Part.Vertex(p))[0]
    # OCCT's extrema can miss on transformed B-splines far from the origin: any point of a face is
    # an upper bound of the distance too, so the projection onto each face's surface, when inside.
    for f in shape.Faces if which is None else which:
        try:
            u, v = f.Surface.parameter(p)
            if f.isPartOfDomain(u, v): d = min(d, (f.Surface.value(u, v) - p).Length)
        except Exception:
            pass
    return d
m2s = 0.0
for q in samples:
    m2s = max(m2s, distance_to_faces(V(*q)))
def pt_tri(q, A=A, B=B, C=C):
    """Distance from q to the nearest triangle ABC (vectorised; the whole mesh by default): the plane
    distance where q projects inside the triangle, else the distance to its nearest edge. (The closest point by barycentric
    coordinates, Ericson's form, erred by 5e-9 on a chamfer's 60 x 0.035 triangles.)"""
    ab, ac = B - A, C - A
    n = np.cross(ab, ac); nn = (n * n).sum(1)
    side = lambda x, y: (np.cross(y - x, q - x) * n).sum(1) >= 0
    inside = (nn > 0) & side(A, B) & side(B, C) & side(C, A)
    plane = np.abs(((q - A) * n).sum(1)) / np.sqrt(np.where(nn > 0, nn, 1.0))
    def segment(x, y):
        d = y - x; dd = (d * d).sum(1)
        t = np.clip(((q - x) * d).sum(1) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
        return np.sqrt(((q - x - d * t[:, None]) ** 2).sum(1))
    edges = np.minimum(np.minimum(segment(A, B), segment(B, C)), segment(C, A))
    return np.where(inside, np.minimum(plane, edges), edges).min()
s2m = 0.0; worst_face = None; count = 0
per_face = max(30, 3000 // max(1, len(shape.Faces)))
n = int(per_face ** 0.5) + 1
for fi, f in enumerate(shape.Faces):
    u0, u1, v0, v1 = f.ParameterRange
    for i in range(n + 1):
        for j in range(n + 1):
            u = u0 + (u1 - u0) * (i + 0.37 * (j % 2)) / (n + 0.37); v = v0 + (v1 - v0) * (j + 0.29 * (i % 2)) / (n + 0.29)
            if not f.isPartOfDomain(u, v): continue
            q = f.valueAt(u, v); d = pt_tri(np.array([q.x, q.y, q.z])); count += 1
            if d > s2m: s2m, worst_face = d, fi + 1
verdict = "OK" if max(m2s, s2m) <= upper * (1 + 1e-9) else "FALSE CERTIFICATE"
print("BRUTE m2s %.6g s2m %.6g (Face %s, %d face samples) upper %.6g -> %s" % (m2s, s2m, worst_face, count, upper, verdict))
if os.environ.get("BF_JSON"):
    # The part's interval is the largest of its faces' (each face against its own triangles), so each
    # face's lower bounds are checked at their witnesses against that face: the mesh -> face witness
    # (a mesh point) at its distance from the face, the face -> mesh witness (a point of the face) at
    # its exact distance from the face's triangles (those whose three vertices lie on the face).
    import json
    doc = json.load(open(os.environ["BF_JSON"]))
    cert = doc["part"]["certificate"] if "part" in doc else doc["certificate"]
    slack = 1e-9 * shape.BoundBox.DiagonalLength  # OCCT's extrema and the distances in double
    rows = [r for r in cert["faces"] if "mesh_to_surface" in r or "surface_to_mesh" in r]
    rows.sort(key=lambda r: -r["lower"])
    rows = rows[:int(os.environ.get("BF_WITNESS_FACES", "8"))]
    checked, false = 0, []
    for r in rows:
        face = shape.Faces[int(r["face"].split()[1]) - 1]
        if "mesh_to_surface" in r:
            w, lower = V(*r["mesh_to_surface"]["witness"]), r["mesh_to_surface"]["lower"]
            d = distance_to_faces(w, [face])
            checked += 1
            if lower > d + slack: false.append("%s mesh->face %.6g > %.6g" % (r["face"], lower, d))
        if "surface_to_mesh" in r:
            w, lower = r["surface_to_mesh"]["witness"], r["surface_to_mesh"]["lower"]
            near = 1e-7 * shape.BoundBox.DiagonalLength + face.Tolerance + max(e.Tolerance for e in face.Edges)
            on = np.array([face.distToShape(Part.Vertex(V(*x)))[0] <= near for x in P])
            mask = on[T[:, 0]] & on[T[:, 1]] & on[T[:, 2]]
            if mask.any():
                d = pt_tri(np.array(w), A[mask], B[mask], C[mask])
                checked += 1
                if lower > d + slack: false.append("%s face->mesh %.6g > %.6g" % (r["face"], lower, d))
    print("LOWER %d witnesses checked on %d faces -> %s" % (checked, len(rows), "OK" if not false else "FALSE LOWER BOUND: " + "; ".join(false)))
