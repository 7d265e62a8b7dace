#!/usr/bin/env python3
"""Whole-part fits against BRepMesh on the shared STEP/IGES parts (docs/BENCHMARKS.md, issue 15).

usage: part_fit_sweep.py SAGITTA OUTDIR [FILE ...]   (files of ../shared/data/cad/step, or ../NAME for the
whole parts one folder up; default: all of both: the 14 STEP/IGES parts, bottle.brep, screw.step, shell1.brep)

Per part: `sagitta fit PART --target-error 1e-3 --relative --json`, then `sagitta peer occt PART
--deflection D --json` at D = 4E, 2E, E, E/2, ... E/32 (E = 1e-3 of the facts' diagonal) until
BRepMesh's certified upper bound is <= the fit's target (for the parts outside facts.json the diagonal
is the one `--relative` took: the fit's target / 1e-3). Prints one Markdown row per part: fit
triangles, certified upper and lower, seconds, faces over the ratio limits (upper > 1.5 x lower on
trimmed faces, > 1.1 x on untrimmed ones; exact faces left out), BRepMesh's deflection, triangles
and certified error, and ours / BRepMesh triangles. The JSON files stay in OUTDIR.
"""
import json
import os
import subprocess
import sys

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "shared", "data", "cad", "step")


def main():
    sagitta, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    facts = {e["file"]: e for e in json.load(open(os.path.join(DATA, "facts.json")))}
    # MAT.brep and wing.brep, one folder up, are Bézier patch files (fitted as patch models).
    for name in sys.argv[3:] or list(facts) + ["../bottle.brep", "../screw.step", "../shell1.brep"]:
        path = os.path.join(DATA, name)
        fit_json = os.path.join(out, os.path.basename(name) + ".fit.json")
        subprocess.run([sagitta, "fit", path, "--target-error", "1e-3", "--relative", "--json", fit_json],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=1800)
        if not os.path.exists(fit_json):
            print("| %s | fit failed |" % name, flush=True)
            continue
        fit = json.load(open(fit_json))
        target = fit["target_error"]
        faces = fit["part"]["certificate"]["faces"]
        diag = facts[name]["diag"] if name in facts else target / 1e-3
        exact = 1e-9 * diag
        over = sum(1 for f in faces if f["certified"] and f["upper"] > exact
                   and f["upper"] > (1.5 if f["trimmed"] else 1.1) * f["lower"])
        brep = None
        for k in (4, 2, 1, 0.5, 0.25, 0.125, 0.0625, 0.03125):
            peer_json = os.path.join(out, "%s.peer.%g.json" % (os.path.basename(name), k))
            subprocess.run([sagitta, "peer", "occt", path, "--deflection", repr(k * 1e-3 * diag),
                            "--json", peer_json], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=900)
            cert = json.load(open(peer_json))["certificate"]
            upper = cert["hausdorff"]["upper"] if cert.get("certified") else float("inf")
            if upper <= target:
                peer = json.load(open(peer_json))
                brep = (peer["deflection"], peer["triangles"], upper)
                break
        if brep:
            theirs = "%.4g | %s | %.4g | %.2f" % (brep[0], format(brep[1], ","), brep[2], fit["triangles"] / brep[1])
        else:
            theirs = "none down to E/32 | – | – | only ours meets E"
        upper = fit["certified_error"] if fit["certified_error"] is not None else float("inf")
        print("| %s | %.4g | **%s** | %.4g | %.4g | %.1f | %d of %d | %s |" % (
            name, target, format(fit["triangles"], ","), upper, fit["certified_lower_bound"], fit["seconds"], over,
            len(faces), theirs), flush=True)


if __name__ == "__main__":
    main()
