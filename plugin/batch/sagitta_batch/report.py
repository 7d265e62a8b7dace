"""DIR/summary.json and a self-contained DIR/report.html (matplotlib PNGs inlined as base64)."""
import base64
import collections
import html
import io
import json
import os

from .child import OUTCOMES


def summarize(rows, params, inputs, submitted, engine_errors, seconds, version):
    """Counts per outcome for this parameter set, totals and throughput of this run."""
    from .store import canonical

    rows = [r for r in rows if r["parameters"] == canonical(params)]
    counts = collections.Counter(r["outcome"] for r in rows)
    ok = [r for r in rows if r["outcome"] == "ok"]
    return {
        "parameters": params,
        "tool_version": version,
        "inputs": inputs,
        "rows": len(rows),
        "processed_this_run": submitted - len(engine_errors),
        "skipped_already_done": inputs - submitted,
        "outcomes": {o: counts.get(o, 0) for o in OUTCOMES},
        "certified": sum(1 for r in ok if r["certified"]),
        "faces": sum(r["faces"] or 0 for r in ok),
        "triangles": sum(r["triangles"] or 0 for r in ok),
        "child_seconds": sum(r["seconds"] for r in rows),
        "wall_seconds": seconds,
        "engine_errors": engine_errors,
    }


def _png(fig):
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()


def _plots(summary, rows):
    """Figures as data URIs: outcomes, time per file against faces, certified Hausdorff interval per file and,
    for --target-error runs, certified error against requested."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    images = []
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.bar(list(summary["outcomes"]), list(summary["outcomes"].values()), color="#4a7ab5")
    ax.set_ylabel("files")
    ax.set_title("Outcomes")
    images.append(("Outcomes per file", _png(fig)))
    plt.close(fig)

    ok = [r for r in rows if r["outcome"] == "ok" and r["faces"]]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.scatter([r["faces"] for r in ok], [r["seconds"] for r in ok], s=14)
    ax.set_xlabel("faces (patches)")
    ax.set_ylabel("seconds per file")
    ax.set_title("Time per file; time per face = slope")
    images.append(("Time per file against its faces", _png(fig)))
    plt.close(fig)

    # Certified parts: their Hausdorff interval; parts certified only face by face: their worst certified face.
    key = lambda r: r["hausdorff_upper"] if r["hausdorff_upper"] is not None else r["worst_face_upper"]
    cert = sorted((r for r in rows if key(r) is not None and key(r) > 0), key=key)
    fig, ax = plt.subplots(figsize=(7, 3.5))
    whole = [(i, r) for i, r in enumerate(cert) if r["hausdorff_upper"] is not None]
    faces = [(i, r) for i, r in enumerate(cert) if r["hausdorff_upper"] is None]
    ax.vlines([i for i, _ in whole], [r["hausdorff_lower"] for _, r in whole], [r["hausdorff_upper"] for _, r in whole],
              lw=4, label="whole mesh: certified [lower, upper]")
    ax.scatter([i for i, _ in faces], [r["worst_face_upper"] for _, r in faces], marker="x", color="#c0392b",
               label="part not certified: upper bound of its worst certified face")
    if cert:
        ax.set_yscale("log")
        ax.set_xticks(range(len(cert)), [os.path.basename(r["path"]) for r in cert], rotation=60, ha="right",
                      fontsize=7)
        ax.legend(fontsize=7)
    ax.set_ylabel("certified Hausdorff distance")
    ax.set_title("Certified error per file (fixed --scheme/--level: no error requested)")
    images.append(("Certified error per file", _png(fig)))
    plt.close(fig)

    fitted = [r for r in rows if r.get("requested_error") and r["hausdorff_upper"] is not None]
    if fitted:  # --target-error runs: every point should lie on or under the diagonal
        fig, ax = plt.subplots(figsize=(5, 4))
        ax.scatter([r["requested_error"] for r in fitted], [r["hausdorff_upper"] for r in fitted], s=14,
                   label="certified upper bound")
        span = [min(r["requested_error"] for r in fitted), max(r["requested_error"] for r in fitted)]
        ax.plot(span, span, color="#888", lw=1, label="requested")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("requested error (absolute)")
        ax.set_ylabel("certified error")
        ax.legend(fontsize=7)
        ax.set_title("Certified error vs requested (sagitta fit)")
        images.append(("Certified error vs requested", _png(fig)))
        plt.close(fig)
    return images


def write(out, summary, rows):
    """Writes OUT/summary.json and OUT/report.html; a failing matplotlib leaves the report without plots."""
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    try:
        images = _plots(summary, rows)
        figures = "".join(f'<figure><img alt="{html.escape(t)}" src="{u}"><figcaption>{html.escape(t)}'
                          f"</figcaption></figure>" for t, u in images)
    except Exception as e:  # the table and summary still stand without the plots
        figures = f"<p>plots unavailable: {html.escape(str(e))}</p>"
    head = ("path", "outcome", "message", "faces", "triangles", "certified", "hausdorff_lower", "hausdorff_upper",
            "worst_face_upper", "requested_error", "fit_parameters", "peer_outcome", "peer_triangles",
            "peer_hausdorff_upper", "seconds")
    table = "".join("<tr>" + "".join(f"<td>{html.escape('' if r[c] is None else str(r[c]))}</td>" for c in head)
                    + "</tr>" for r in rows)
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>sagitta batch report</title>
<style>body{{font-family:sans-serif;margin:2em}}td,th{{border:1px solid #ccc;padding:2px 6px;font-size:12px}}
table{{border-collapse:collapse}}figure{{display:inline-block;margin:0 1em 1em 0}}</style></head><body>
<h1>sagitta batch</h1><pre>{html.escape(json.dumps(summary, indent=2))}</pre>{figures}
<table><tr>{''.join(f'<th>{c}</th>' for c in head)}</tr>{table}</table></body></html>"""
    with open(os.path.join(out, "report.html"), "w") as f:
        f.write(page)
