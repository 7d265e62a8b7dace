#!/usr/bin/env python3
"""BRepMesh's meshes of the shared parts, certified (docs/ACCURACY.md and docs/BENCHMARKS.md, issues 15 and 17).

usage: peer_sweep.py SAGITTA OUTDIR [FILE ...]   (files of ../shared/data/cad/step; default: all)

Per part and per deflection D = 1e-2, 1e-3, 1e-4 of the facts' diagonal: `sagitta peer occt PART
--deflection D --json`. Prints one Markdown row per run: triangles, BRepMesh's seconds, faces
certified, the certified Hausdorff interval, lower / D and upper / D, crack edges, and the
certificate's seconds with its ratio to BRepMesh's meshing time. The JSON files stay in OUTDIR.
"""
import json
import os
import subprocess
import sys

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "shared", "data", "cad", "step")


def g(x):
    return "%.4g" % x


def main():
    sagitta, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    facts = {e["file"]: e for e in json.load(open(os.path.join(DATA, "facts.json")))}
    print("| part | deflection (of diag) | D | triangles | BRepMesh s | faces certified | certified Hausdorff "
          "[lower, upper] | lower / D | upper / D | crack edges | certificate s | certificate / BRepMesh |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in sys.argv[3:] or list(facts):
        for r in (1e-2, 1e-3, 1e-4):
            d = r * facts[name]["diag"]
            path = os.path.join(out, "%s.%g.json" % (name, r))
            subprocess.run([sagitta, "peer", "occt", os.path.join(DATA, name), "--deflection", repr(d), "--json", path],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=3600)
            if not os.path.exists(path):
                print("| %s | %g | %s | peer failed |" % (name, r, g(d)), flush=True)
                continue
            j = json.load(open(path))
            c = j["certificate"]
            h = c["hausdorff"]
            upper = h["upper"] if c["certified"] and h.get("upper") is not None else None
            mesh_s, cert_s = j["mesh_seconds"], j["validate_seconds"]
            print("| %s | %g | %s | %s | %.3f | %d/%d | [%s, %s] | %.2f | %s | %d | %.3f | %.1f |" % (
                name, r, g(d), format(j["triangles"], ","), mesh_s, c["faces_certified"], c["faces_total"],
                g(h["lower"]), g(upper) if upper is not None else "not certified", h["lower"] / d,
                "%.2f" % (upper / d) if upper is not None else "–", j["crack_edges"], cert_s,
                cert_s / mesh_s if mesh_s > 0 else float("inf")), flush=True)


if __name__ == "__main__":
    main()
