"""The batch: expand the inputs, skip what results.sqlite already has, run the rest on Dask (a LocalCluster,
or an existing scheduler) one child process per file, record each result as it arrives, then report."""
import datetime
import hashlib
import logging
import os
import shutil
import subprocess
import sys
import time

from . import child, report
from .store import Store, canonical, file_sha256

EXTENSIONS = (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".bpt", ".rib")


def expand_inputs(inputs):
    """Files as given; folders recursively (files with a known extension, sorted); @list.txt: one input a
    line (blank lines and # comments skipped, relative paths from the list's folder). Raises on a missing path."""
    files = []
    for item in inputs:
        item = os.fspath(item)
        if item.startswith("@"):
            base = os.path.dirname(os.path.abspath(item[1:]))
            with open(item[1:]) as f:
                lines = [line.strip() for line in f]
            files += expand_inputs([os.path.join(base, line) for line in lines if line and not line.startswith("#")])
        elif os.path.isdir(item):
            for root, dirs, names in os.walk(item):
                dirs.sort()
                files += [os.path.join(root, n) for n in sorted(names) if n.lower().endswith(EXTENSIONS)]
        elif os.path.isfile(item):
            files.append(item)
        else:
            raise FileNotFoundError(f"no such input: {item}")
    return [os.path.abspath(f) for f in files]


def find_sagitta():
    """The sagitta executable: $SAGITTA_EXE (set by `sagitta batch`), else `sagitta` in PATH."""
    exe = os.environ.get("SAGITTA_EXE") or shutil.which("sagitta")
    if not exe:
        raise FileNotFoundError("the sagitta executable was not found (set SAGITTA_EXE)")
    return os.path.abspath(exe)


def tool_version(exe):
    """`sagitta --version` when it answers, else the binary's sha256 prefix and modification time."""
    try:
        out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=30)
        if out.returncode == 0 and out.stdout.strip():
            return out.stdout.strip().splitlines()[0]
    except (OSError, subprocess.TimeoutExpired):
        pass
    with open(exe, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()[:12]
    mtime = datetime.datetime.fromtimestamp(os.path.getmtime(exe), datetime.timezone.utc)
    return f"sagitta binary {digest} built {mtime.strftime('%Y-%m-%dT%H:%M:%SZ')}"


class Progress:
    """One stderr line: files done/total, rate, ETA (rewritten in place on a terminal, every 5 s otherwise)."""

    def __init__(self, total, quiet=False):
        self.total, self.done, self.start, self.last = total, 0, time.monotonic(), 0.0
        self.quiet, self.tty = quiet, sys.stderr.isatty()

    def step(self, final=False):
        self.done += not final
        now = time.monotonic()
        if self.quiet or (not final and (self.done == self.total or (not self.tty and now - self.last < 5))):
            return
        self.last = now
        rate = self.done / max(now - self.start, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        line = f"batch: {self.done}/{self.total} files, {rate * 60:.1f} files/min, ETA {eta:.0f} s"
        sys.stderr.write(("\r" + line + ("\n" if final else "")) if self.tty else line + "\n")
        sys.stderr.flush()


def _client(scheduler, workers):
    from dask.distributed import Client, LocalCluster  # imported here: a clear error if Dask is missing

    if scheduler:
        return Client(scheduler), None
    # Dask's own logs stay quiet (their shutdown races print tracebacks); lost tasks surface as engine errors.
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.CRITICAL)
    return Client(cluster), cluster


def _pending(files, params, store):
    """(sha256, path) of every input not yet in the database; the same bytes under two paths run once."""
    done, seen, todo = store.done_keys(), set(), []
    key_params = canonical(params)
    for path in files:
        sha = file_sha256(path)
        if (sha, key_params) not in done and sha not in seen:
            seen.add(sha)
            todo.append((sha, path))
    return todo


def batch_parameters(scheme, level, command, target_error, relative, peer, deflection):
    """The parameter set (the row key's `parameters`): every option that changes a file's result."""
    if target_error is not None:
        if target_error <= 0:
            raise ValueError("--target-error must be positive")
        params = {"command": "fit", "scheme": scheme, "target_error": target_error, "relative": relative or None}
    elif relative:
        raise ValueError("--relative needs --target-error")
    else:
        params = {"command": command, "scheme": scheme, "level": level}
    if peer not in (None, "occt"):
        raise ValueError(f"unknown peer {peer!r} (occt)")
    if deflection is not None and peer is None:
        raise ValueError("--deflection needs --peer occt")
    params.update(peer=peer, deflection=deflection)
    return {k: v for k, v in params.items() if v is not None}


def run(inputs, out, scheme=None, level=2, command="validate", workers=None, scheduler=None, timeout=600.0,
        memory=None, quiet=False, target_error=None, relative=False, peer=None, deflection=None):
    """Runs the batch and returns the summary dict (also written to OUT/summary.json, with OUT/report.html).
    Files already in OUT/results.sqlite with the same sha256 and parameters are skipped. With target_error,
    each file runs `sagitta fit` instead (level and command ignored; relative: a fraction of the box
    diagonal); with peer="occt", also `sagitta peer occt` (deflection: its --deflection)."""
    params = batch_parameters(scheme, level, command, target_error, relative, peer, deflection)
    files = expand_inputs(inputs)
    os.makedirs(out, exist_ok=True)
    exe = find_sagitta()
    version = tool_version(exe)
    store = Store(os.path.join(out, "results.sqlite"))
    todo = _pending(files, params, store)
    progress = Progress(len(todo), quiet)
    engine_errors = []
    started = time.monotonic()
    if todo:
        from dask.distributed import as_completed

        client, cluster = _client(scheduler, workers or os.cpu_count())
        try:
            futures = {
                client.submit(child.run_file, exe, path, params, timeout, memory, key=f"sagitta-{sha}-{i}",
                              pure=False): (sha, path)
                for i, (sha, path) in enumerate(todo)
            }
            for future in as_completed(futures):
                sha, path = futures[future]
                try:
                    result = future.result()
                except Exception as e:  # the engine lost the task (e.g. its workers kept dying): not recorded
                    engine_errors.append({"path": path, "error": f"{type(e).__name__}: {e}"})
                    continue
                finished = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
                store.insert(dict(result, sha256=sha, parameters=canonical(params), path=path,
                                  tool_version=version, finished_at=finished))
                progress.step()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    progress.step(final=True)
    summary = report.summarize(store.rows(), params, len(files), len(todo), engine_errors,
                               time.monotonic() - started, version)
    report.write(out, summary, store.rows())
    store.close()
    return summary
