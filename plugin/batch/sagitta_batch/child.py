"""One file, one child process: runs the sagitta CLI under a wall-time limit and a memory cap and turns
whatever happens into a result dict. Runs on a Dask worker; imports nothing from Dask."""
import ctypes
import json
import os
import resource
import signal
import subprocess
import tempfile
import time

OUTCOMES = ("ok", "bad_input", "crashed", "timeout", "out_of_memory")
# Allocation failures under RLIMIT_AS, and sagitta's own refusal of work estimated above --max-memory.
_OOM_TEXT = ("bad_alloc", "MemoryError", "Cannot allocate memory", "out of memory", "ENOMEM", "more than --max-memory")
_LIBC = ctypes.CDLL(None, use_errno=True)
_PR_SET_PDEATHSIG = 1


def _child_setup(gib):
    """preexec_fn: the child gets SIGKILL when the worker thread that started it dies (a killed worker leaves
    no orphan), and its address space is capped at `gib` GiB (RLIMIT_AS; no cap when gib is 0 or None)."""

    def apply():
        _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if gib:
            limit = int(gib * 2**30)
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    return apply


def _fault_command(path):
    """The test hook: SAGITTA_BATCH_TEST_FAULT="kind:basename;..." replaces the child for that file.
    crash: SIGSEGV; hang: sleeps for an hour; hog: allocates 16 GiB; delay: waits 1 s, then runs sagitta."""
    spec = os.environ.get("SAGITTA_BATCH_TEST_FAULT", "")
    for item in filter(None, spec.split(";")):
        kind, _, name = item.partition(":")
        if name == os.path.basename(path):
            return {
                "crash": ["/bin/sh", "-c", "kill -SEGV $$"],
                "hang": ["/bin/sh", "-c", "exec sleep 3600"],
                "hog": ["/usr/bin/python3", "-c", "b = bytearray(2**34)"],
                "delay": "delay",
            }[kind]
    return None


def sagitta_command(exe, path, params, json_out, memory=None, target=None):
    """The sagitta command line for one file: `validate FILE --json OUT`, `tessellate FILE --stats OUT` or
    `fit FILE --target-error TARGET --json OUT`; with a memory cap, also `--max-memory GiB` so that sagitta
    refuses work estimated above it up front."""
    command = params.get("command", "validate")
    if command == "fit":
        cmd = [exe, "fit", path, "--target-error", repr(target), "--json", json_out]
    else:
        cmd = [exe, command, path, "--json" if command == "validate" else "--stats", json_out]
    if params.get("scheme"):
        cmd += ["--scheme", params["scheme"]]
    if params.get("level") is not None and command != "fit":
        cmd += ["--level", str(params["level"])]
    if memory:
        cmd += ["--max-memory", str(memory)]
    return cmd


def _last_line(text):
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def _metrics(report):
    """faces, faces_tessellated, triangles, certified, hausdorff interval (None unless certified), worst face
    from the sagitta JSON of a CAD part (faces, certificate.*) or of a patch model (patches, hausdorff)."""
    cert = report.get("certificate", report)
    certified = bool(report.get("certified", False))
    hausdorff = cert.get("hausdorff") or {}
    faces = report.get("faces", report.get("patches"))
    face_list = cert.get("faces") if "certificate" in report else None  # a patch model's "faces" is a count
    certified_faces = [f for f in face_list or [] if f.get("certified")]
    worst = max(certified_faces, key=lambda f: f.get("upper") or 0, default=None)
    return {
        "faces": faces,
        "faces_tessellated": report.get("faces_tessellated", faces),
        "triangles": report.get("triangles"),
        "certified": certified,
        "hausdorff_lower": hausdorff.get("lower") if certified else None,
        "hausdorff_upper": hausdorff.get("upper") if certified else None,
        "worst_face": worst.get("face") if worst else None,
        "worst_face_upper": worst.get("upper") if worst else None,
    }


def classify(returncode, stderr, timed_out):
    """(outcome, message) for a finished child: timeout, out_of_memory (allocation failure text), crashed
    (killed by a signal), bad_input (any other non-zero exit, with its last stderr line) or ok."""
    last = _last_line(stderr)
    if timed_out:
        return "timeout", "killed after the wall-time limit"
    if returncode != 0 and any(text in stderr for text in _OOM_TEXT):
        return "out_of_memory", last
    if returncode < 0:
        name = signal.Signals(-returncode).name if -returncode in signal.valid_signals() else str(-returncode)
        return "crashed", f"signal {name}" + (f": {last}" if last else "")
    if returncode != 0:
        return "bad_input", last or f"exit code {returncode}"
    return "ok", ""


def _fit_metrics(report):
    """The row's fields from `sagitta fit --json`: the chosen parameters, triangles, certified interval."""
    keys = ("scheme", "level", "threshold", "segments", "base_level", "per_patch")
    return {
        "triangles": report.get("triangles"),
        "certified": report.get("certified_error") is not None,
        "hausdorff_lower": report.get("certified_lower_bound"),
        "hausdorff_upper": report.get("certified_error"),
        "fit_parameters": json.dumps({k: report[k] for k in keys if k in report}, sort_keys=True),
    }


def _run_child(cmd, timeout, memory):
    """Runs one child in its own session; (outcome, message). A child past `timeout` has its group killed."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            errors="replace", start_new_session=True, preexec_fn=_child_setup(memory))
    timed_out = False
    try:
        _, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        os.killpg(proc.pid, signal.SIGKILL)
        _, stderr = proc.communicate()
    return classify(proc.returncode, stderr, timed_out)


def _read_json(json_out, metrics, result):
    """Adds metrics(report) to result, or turns result into bad_input when the report is unreadable."""
    try:
        with open(json_out) as f:
            result.update(metrics(json.load(f)))
    except (OSError, ValueError) as e:
        result.update(outcome="bad_input", message=f"no readable JSON report: {e}")


def model_diagonal(exe, path, tmp, timeout, memory):
    """(outcome, message, diagonal): the diagonal of the bounding box of `sagitta tessellate FILE --level 1`'s
    vertices. They lie on the surface, so this is at most the surface's box diagonal (a relative target
    scaled by it is never looser than asked)."""
    obj = os.path.join(tmp, "box.obj")
    outcome, message = _run_child([exe, "tessellate", path, "--level", "1", "--out", obj], timeout, memory)
    if outcome != "ok":
        return outcome, message, None
    lo, hi = [float("inf")] * 3, [float("-inf")] * 3
    with open(obj) as f:
        for line in f:
            if line.startswith("v "):
                xyz = [float(t) for t in line.split()[1:4]]
                lo, hi = [min(a, b) for a, b in zip(lo, xyz)], [max(a, b) for a, b in zip(hi, xyz)]
    if lo[0] > hi[0]:
        return "bad_input", "no vertices to measure the model's box", None
    return "ok", "", sum((b - a) ** 2 for a, b in zip(lo, hi)) ** 0.5


def _peer(exe, path, params, tmp, timeout, memory):
    """`sagitta peer occt FILE [--deflection D] --json OUT`: OCCT's triangles and certified interval (peer_*)."""
    json_out = os.path.join(tmp, "peer.json")
    cmd = [exe, "peer", "occt", path, "--json", json_out]
    if params.get("deflection") is not None:
        cmd += ["--deflection", repr(params["deflection"])]
    if memory:
        cmd[2:2] = ["--max-memory", str(memory)]
    outcome, message = _run_child(cmd, timeout, memory)
    peer = {"outcome": outcome, "message": message}
    if outcome == "ok":
        _read_json(json_out, lambda r: {"triangles": r.get("triangles"),
                                        "hausdorff_lower": (r.get("hausdorff") or {}).get("lower"),
                                        "hausdorff_upper": (r.get("hausdorff") or {}).get("upper")}, peer)
    return {f"peer_{k}": v for k, v in peer.items()}


def run_file(exe, path, params, timeout=None, memory=None):
    """Processes one file in its own child process(es) and returns its result dict (never raises for what
    a child does: a crash, a hang, a memory blow-up or a bad file is the returned outcome). With
    params["command"] == "fit" the target is params["target_error"], times the model's box diagonal when
    params["relative"]; with params["peer"] == "occt", OCCT's mesh is certified too (peer_* fields)."""
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="sagitta-batch-") as tmp:
        json_out = os.path.join(tmp, "out.json")
        target, outcome, message = params.get("target_error"), "ok", ""
        result = {}
        if params.get("command") == "fit" and params.get("relative"):
            outcome, message, diagonal = model_diagonal(exe, path, tmp, timeout, memory)
            result["model_diagonal"] = diagonal
            target = target * diagonal if diagonal else None
        result["requested_error"] = target
        if outcome == "ok":
            cmd = sagitta_command(exe, path, params, json_out, memory, target)
            fault = _fault_command(path)
            if fault == "delay":
                cmd = ["/bin/sh", "-c", 'sleep 1; exec "$@"', "sh"] + cmd
            elif fault:
                cmd = fault
            outcome, message = _run_child(cmd, timeout, memory)
        result.update(outcome=outcome, message=message)
        if outcome == "ok":
            _read_json(json_out, _fit_metrics if params.get("command") == "fit" else _metrics, result)
        if params.get("peer") == "occt":
            result.update(_peer(exe, path, params, tmp, timeout, memory))
        result["seconds"] = time.monotonic() - start
    return result
