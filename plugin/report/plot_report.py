#!/usr/bin/python3
"""Plots for `sagitta report`: reads report.json, writes model_<k>_triangles.png and
model_<k>_time.png (certified error against triangles / tessellation time, log-log; for a whole CAD
part, triangles / time against the level) into OUT_DIR.
Usage: plot_report.py REPORT_JSON OUT_DIR"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"uniform": "#1f77b4", "esc": "#d62728", "pn": "#2ca02c", "occt": "#9467bd"}
MARKERS = {"uniform": "o", "esc": "s", "pn": "^", "occt": "D"}
NAMES = {"uniform": "uniform (levels 1-5)", "esc": "ESC (L 3 and 7, thresholds)",
         "pn": "PN (base level 2, levels 1-6)", "occt": "OCCT BRepMesh (deflections)"}


def certified(points):
    return [p for p in points if p.get("certified_error") is not None and p["certified_error"] > 0]


def plot(model, index, cost_key, out_dir):
    points = model["points"]
    fig, ax = plt.subplots(figsize=(8, 5.6), dpi=100)
    front_key = "pareto_triangles" if cost_key == "triangles" else "pareto_time"
    front = [points[i] for i in model[front_key]]
    scale = 1e3 if cost_key == "seconds" else 1.0
    if front:
        ax.step([p[cost_key] * scale for p in front], [p["certified_error"] for p in front], where="post",
                color="#f2b400", linewidth=9, alpha=0.45, zorder=1, label="Pareto front")
    for scheme in ["uniform", "esc", "pn", "occt"]:
        mine = certified([p for p in points if p["scheme"] == scheme])
        if not mine:
            continue
        mine.sort(key=lambda p: p[cost_key])
        xs = [max(p[cost_key] * scale, 1e-3) for p in mine]
        ys = [p["certified_error"] for p in mine]
        ax.plot(xs, ys, linestyle="-" if cost_key == "triangles" else "none", marker=MARKERS[scheme],
                color=COLOURS[scheme], markersize=7, linewidth=1.5, zorder=3, label=NAMES[scheme])
        fit = model["schemes"].get(scheme, {}).get("fit")
        if fit and cost_key == "triangles":
            lo, hi = min(xs) / 1.5, max(xs) * 1.5
            grid = [lo * (hi / lo) ** (k / 40.0) for k in range(41)]
            floor = fit.get("F", 0.0)
            label = "fit %s: %s%.3g T^%.2f" % (scheme, "%.3g + " % floor if "F" in fit else "", fit["C"], fit["p"])
            ax.plot(grid, [floor + fit["C"] * t ** fit["p"] for t in grid], linestyle="--", color=COLOURS[scheme],
                    linewidth=1, alpha=0.8, zorder=2, label=label)
    ref = model.get("reference_error")
    if ref:
        ax.axhline(ref, color="#555555", linestyle=":", linewidth=1.2, label="reference error %.3g" % ref)
    ax.set_xscale("log")
    ax.set_yscale("log")
    if cost_key == "triangles":
        ax.set_xlabel("triangles (count, log scale)", fontsize=12)
        ax.set_title("%s: certified error against triangles" % model["name"], fontsize=13)
    else:
        ax.set_xlabel("tessellation time (ms, log scale)", fontsize=12)
        ax.set_title("%s: certified error against tessellation time" % model["name"], fontsize=13)
    ax.set_ylabel("certified Hausdorff upper bound (model units, log scale)", fontsize=11)
    ax.grid(True, which="major", alpha=0.35)
    ax.grid(True, which="minor", alpha=0.12)
    ax.legend(fontsize=8.5, loc="best", framealpha=0.9)
    fig.tight_layout()
    path = os.path.join(out_dir, "model_%d_%s.png" % (index, "triangles" if cost_key == "triangles" else "time"))
    tmp = path + ".tmp.png"
    fig.savefig(tmp)
    plt.close(fig)
    os.replace(tmp, path)
    print(path)


def plot_part(model, index, out_dir):
    """A whole CAD part: triangles and tessellation time against the uniform level (model_<k>_triangles.png,
    model_<k>_time.png); a level's certified Hausdorff bound is marked only when every face is certified."""
    rows = model["levels"]
    levels = [r["level"] for r in rows]
    for key, ylabel, title, scale, name in [
            ("triangles", "triangles (count, log scale)", "triangles against level", 1.0, "triangles"),
            ("seconds", "tessellation time (ms, log scale)", "tessellation time against level", 1e3, "time")]:
        fig, ax = plt.subplots(figsize=(8, 5.6), dpi=100)
        ax.plot(levels, [max(r[key] * scale, 1e-3) for r in rows], marker="o", color=COLOURS["uniform"],
                markersize=7, linewidth=1.5, label="part mesher, uniform levels")
        certified_rows = [r for r in rows if r.get("certified_hausdorff")]
        for r in certified_rows:
            ax.annotate("certified <= %.3g" % r["certified_hausdorff"]["upper"], (r["level"], r[key] * scale),
                        textcoords="offset points", xytext=(6, -12), fontsize=8.5)
        ax.set_yscale("log")
        ax.set_xticks(levels)
        ax.set_xlabel("uniform level", fontsize=12)
        ax.set_ylabel(ylabel, fontsize=11)
        ax.set_title("%s (whole part): %s" % (model["name"], title), fontsize=13)
        ax.grid(True, which="major", alpha=0.35)
        ax.legend(fontsize=8.5, loc="best", framealpha=0.9)
        fig.tight_layout()
        path = os.path.join(out_dir, "model_%d_%s.png" % (index, name))
        tmp = path + ".tmp.png"
        fig.savefig(tmp)
        plt.close(fig)
        os.replace(tmp, path)
        print(path)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_report.py REPORT_JSON OUT_DIR")
    with open(sys.argv[1]) as f:
        report = json.load(f)
    for index, model in enumerate(report.get("models", [])):
        if model.get("kind") == "part":
            plot_part(model, index, sys.argv[2])
            continue
        plot(model, index, "triangles", sys.argv[2])
        plot(model, index, "seconds", sys.argv[2])


if __name__ == "__main__":
    main()
