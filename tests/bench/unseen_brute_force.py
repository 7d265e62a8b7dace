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
certified lower bounds are checked too, at their witnesses: the mesh -> surface witness (a mesh
point) is at most its measured distance from the faces away from them, and the surface -> mesh
witness (a surface point) at most its exact distance from the triangles; a lower bound above that
is a FALSE LOWER BOUND (the witness is where the bound claims the distance is reached)."""
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
def distance_to_faces(p):
    """At least the distance from p to the shape's faces (a distance to some of their points)."""
    d = faces.distToShape(Part.Vertex(p))[0]
    # OCCT's extrema can miss on transformed B-splines far from the origin: any point of a face is
    # an upper bound of the distance too, so the projection onto each face's surface, when inside.
    for f in shape.Faces:
        try:
            u, v = f.Surface.parameter(p)
            if f.isPartOfDomain(u, v): d = min(d, (f.Surface.value(u, v) - p).Length)
        except Exception:
            pass
    return d
m2s = 0.0
for q in samples:
    m2s = max(m2s, distance_to_faces(V(*q)))
def pt_tri(q):
    # distance from q to every triangle (Ericson, vectorised)
    ab, ac, ap = B - A, C - A, q - A
    d1 = (ab * ap).sum(1); d2 = (ac * ap).sum(1)
    bp = q - B; d3 = (ab * bp).sum(1); d4 = (ac * bp).sum(1)
    cp = q - C; d5 = (ab * cp).sum(1); d6 = (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4; vb = d5 * d2 - d1 * d6; vc = d1 * d4 - d3 * d2
    den = va + vb + vc; den[den == 0] = 1e-300
    v = vb / den; w = vc / den
    X = A + ab * v[:, None] + ac * w[:, None]
    # regions
    m = (d1 <= 0) & (d2 <= 0); X[m] = A[m]
    m = (d3 >= 0) & (d4 <= d3); X[m] = B[m]
    m = (d6 >= 0) & (d5 <= d6); X[m] = C[m]
    m = (vc <= 0) & (d1 >= 0) & (d3 <= 0) & ~((d1 <= 0) & (d2 <= 0)); t = d1 / np.where(d1 - d3 == 0, 1e-300, d1 - d3); X[m] = (A + ab * t[:, None])[m]
    m = (vb <= 0) & (d2 >= 0) & (d6 <= 0) & ~((d1 <= 0) & (d2 <= 0)); t = d2 / np.where(d2 - d6 == 0, 1e-300, d2 - d6); X[m] = (A + ac * t[:, None])[m]
    m = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0); t = (d4 - d3) / np.where((d4 - d3) + (d5 - d6) == 0, 1e-300, (d4 - d3) + (d5 - d6)); X[m] = (B + (C - B) * t[:, None])[m]
    return np.sqrt(((X - q) ** 2).sum(1)).min()
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
    import json
    doc = json.load(open(os.environ["BF_JSON"]))
    cert = doc["part"]["certificate"] if "part" in doc else doc["certificate"]
    # Measuring tolerance: OCCT's extrema and the point-triangle distance in double.
    slack = 1e-9 * shape.BoundBox.DiagonalLength
    for key, measure in (("mesh_to_surface", distance_to_faces), ("surface_to_mesh", lambda p: pt_tri(np.array([p.x, p.y, p.z])))):
        part = cert.get(key, {})
        w, lower = part.get("witness"), part.get("lower", 0.0)
        if not w or not lower:
            continue
        d = measure(V(*w))
        print("LOWER %s %.6g at witness, measured %.6g -> %s" % (key, lower, d, "OK" if lower <= d + slack else "FALSE LOWER BOUND"))
