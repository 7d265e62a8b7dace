"""`sagitta batch` end to end (issue 19). Each test builds its corpus in a temporary folder from the shared data
and planted faults (SAGITTA_BATCH_TEST_FAULT makes the child runner crash, hang or over-allocate for a named
file), runs the real CLI with 2 workers, and checks results.sqlite against references computed independently:
outcomes from how each file was made, patch counts from the .bpt headers, triangle counts and certified intervals
from a direct `sagitta validate` run."""
import json
import os
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
import unittest

SAGITTA = os.environ["SAGITTA"]
DATA = os.environ["SHARED_DATA"]
PYTHON = "/usr/bin/python3"

try:
    import distributed  # noqa: F401
except ImportError:
    sys.exit("test_batch: Dask.distributed is missing: run .ci/install-deps (Debian python3-distributed)")

REAL = ["teacup.bpt", "teapot.bpt", "teaspoon.bpt", "cad/step/pr1ct.stp", "cad/wing.brep", "cad/step/OCC2368.stp"]


def make_corpus(folder, names):
    os.makedirs(folder, exist_ok=True)
    for name in names:
        shutil.copy(os.path.join(DATA, name), folder)
    return folder


def rows(out):
    with sqlite3.connect(os.path.join(out, "results.sqlite")) as db:
        db.row_factory = sqlite3.Row
        return {os.path.basename(r["path"]): dict(r) for r in db.execute("SELECT * FROM results")}


def batch(args, env=None, **kwargs):
    full_env = dict(os.environ, **(env or {}))
    return subprocess.run([SAGITTA, "batch", *args], env=full_env, capture_output=True, text=True, timeout=300, **kwargs)


def bpt_patches(path):
    with open(path) as f:
        return int(f.readline().split()[0])


def direct_json(*args):
    """The reference: `sagitta ARGS --json FILE` run directly, its JSON report."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([SAGITTA, *args, "--json", f"{tmp}/r.json"], check=True, capture_output=True)
        with open(f"{tmp}/r.json") as f:
            return json.load(f)


def direct_validate(path, level):
    """The reference: sagitta validate run directly on the file."""
    return direct_json("validate", path, "--level", str(level))


class PlantedFaults(unittest.TestCase):
    def test_each_fault_recorded_others_ok_and_rerun_is_a_noop(self):
        with tempfile.TemporaryDirectory() as tmp:
            corpus = make_corpus(f"{tmp}/corpus", REAL[:4])
            with open(os.path.join(DATA, "cad/step/pr1ct.stp"), "rb") as f:
                step = f.read()
            with open(f"{corpus}/truncated.step", "wb") as f:
                f.write(step[: len(step) // 3])
            for name in ("crash", "hang", "hog"):  # distinct bytes: each its own sha256
                with open(f"{corpus}/{name}.step", "wb") as f:
                    f.write(step + f"/* {name} */".encode())
            fault = {"SAGITTA_BATCH_TEST_FAULT": "crash:crash.step;hang:hang.step;hog:hog.step"}
            args = [corpus, "--out", f"{tmp}/out", "--level", "2", "--workers", "2", "--timeout", "8", "--memory", "3"]
            run = batch(args, env=fault)
            self.assertEqual(run.returncode, 0, run.stderr)
            got = rows(f"{tmp}/out")
            expected = {"truncated.step": "bad_input", "crash.step": "crashed", "hang.step": "timeout",
                        "hog.step": "out_of_memory"}
            expected.update({os.path.basename(n): "ok" for n in REAL[:4]})
            self.assertEqual({k: r["outcome"] for k, r in got.items()}, expected)
            self.assertIn("not a readable STEP file", got["truncated.step"]["message"])
            self.assertIn("SIGSEGV", got["crash.step"]["message"])
            self.assertGreaterEqual(got["hang.step"]["seconds"], 8)
            for name in ("teacup.bpt", "teapot.bpt", "teaspoon.bpt"):
                self.assertEqual(got[name]["faces"], bpt_patches(f"{corpus}/{name}"))
            for name in ("teacup.bpt", "pr1ct.stp"):
                ref = direct_validate(f"{corpus}/{name}", 2)
                self.assertEqual(got[name]["triangles"], ref["triangles"])
                self.assertEqual(bool(got[name]["certified"]), ref["certified"])
                if ref["certified"]:
                    self.assertEqual(got[name]["hausdorff_upper"], ref.get("certificate", ref)["hausdorff"]["upper"])
                else:
                    self.assertIsNone(got[name]["hausdorff_upper"])
            self.assertEqual(json.loads(got["teacup.bpt"]["parameters"]), {"command": "validate", "level": 2})
            with open(f"{tmp}/out/report.html") as f:
                page = f.read()
            self.assertEqual(page.count("data:image/png;base64,"), 3)
            with open(f"{tmp}/out/summary.json") as f:
                summary = json.load(f)
            self.assertEqual(summary["outcomes"], {"ok": 4, "bad_input": 1, "crashed": 1, "timeout": 1,
                                                   "out_of_memory": 1})

            again = batch(args, env=fault)  # resume: nothing new to do, the database unchanged
            self.assertEqual(again.returncode, 0, again.stderr)
            self.assertIn("0 processed now, 8 already done", again.stdout)
            self.assertEqual(rows(f"{tmp}/out"), got)

    def test_work_estimated_above_the_memory_cap_is_out_of_memory(self):
        with tempfile.TemporaryDirectory() as tmp:
            corpus = make_corpus(f"{tmp}/corpus", ["teapot.bpt"])  # level 9: about 2.1 GiB of triangles
            run = batch([corpus, "--out", f"{tmp}/out", "--level", "9", "--workers", "1", "--memory", "1"])
            self.assertEqual(run.returncode, 0, run.stderr)
            got = rows(f"{tmp}/out")["teapot.bpt"]
            self.assertEqual(got["outcome"], "out_of_memory")
            self.assertIn("more than --max-memory 1", got["message"])

def control_box_diagonal(path):
    """The diagonal of a .bpt's control-point box: it contains the Bézier surface (convex hull property)."""
    with open(path) as f:
        lines = [line.split() for line in f if line.strip()]
    points = [[float(t) for t in line] for line in lines[1:] if len(line) == 3]
    lo, hi = [min(c) for c in zip(*points)], [max(c) for c in zip(*points)]
    return sum((b - a) ** 2 for a, b in zip(lo, hi)) ** 0.5


class TargetErrorAndPeer(unittest.TestCase):
    def assert_fit_row_is_the_direct_fit(self, row, path):
        """A fit row at 1e-2 of the model's diagonal met its target, and its numbers are those of
        `sagitta fit PATH` run directly at the same target; returns that fit's report."""
        self.assertEqual(row["outcome"], "ok", row["message"])
        self.assertAlmostEqual(row["requested_error"], 0.01 * row["model_diagonal"])
        self.assertLessEqual(row["hausdorff_lower"], row["hausdorff_upper"])
        self.assertLessEqual(row["hausdorff_upper"], row["requested_error"])
        ref = direct_json("fit", path, "--target-error", repr(row["requested_error"]))
        self.assertEqual(row["triangles"], ref["triangles"])
        self.assertEqual(row["hausdorff_upper"], ref["certified_error"])
        return ref

    def test_relative_target_fit_cad_refusal_and_occt_peer(self):
        with tempfile.TemporaryDirectory() as tmp:
            corpus = make_corpus(f"{tmp}/corpus", ["teacup.bpt", "cad/step/pr1ct.stp"])
            run = batch([corpus, "--out", f"{tmp}/out", "--target-error", "1e-2", "--relative", "--peer", "occt",
                         "--deflection", "0.5", "--workers", "2", "--timeout", "200"])
            self.assertEqual(run.returncode, 0, run.stderr)
            got = rows(f"{tmp}/out")
            cup, part = got["teacup.bpt"], got["pr1ct.stp"]
            self.assertEqual(json.loads(cup["parameters"]), {"command": "fit", "target_error": 0.01, "relative": True,
                                                             "peer": "occt", "deflection": 0.5})
            # The diagonal is measured on surface points: inside the control-point box, and close to it.
            box = control_box_diagonal(f"{corpus}/teacup.bpt")
            self.assertTrue(0.5 * box < cup["model_diagonal"] <= box * (1 + 1e-9), (cup["model_diagonal"], box))
            ref = self.assert_fit_row_is_the_direct_fit(cup, f"{corpus}/teacup.bpt")
            self.assertEqual(json.loads(cup["fit_parameters"])["level"], ref["level"])
            # A whole CAD part is fitted as a direct `sagitta fit` is (uniform segments, edge tolerance): pr1ct's
            # spheres, re-triangulated under the edge tolerance, have poles; every face is certified, the
            # target met, and the numbers are the direct fit's.
            self.assert_fit_row_is_the_direct_fit(part, f"{corpus}/pr1ct.stp")
            self.assertEqual(part["peer_outcome"], "ok", part["peer_message"])
            self.assertGreater(part["peer_triangles"], 0)
            ref = direct_json("peer", "occt", f"{corpus}/pr1ct.stp", "--deflection", "0.5")
            self.assertEqual(part["peer_triangles"], ref["triangles"])
            self.assertEqual(part["peer_hausdorff_lower"], ref["hausdorff"]["lower"])
            with open(f"{tmp}/out/report.html") as f:
                self.assertEqual(f.read().count("data:image/png;base64,"), 4)  # with certified vs requested

    def test_database_without_the_new_columns_gets_them_at_open(self):
        from sagitta_batch import store

        with tempfile.TemporaryDirectory() as tmp:
            path = f"{tmp}/old.sqlite"
            old = store.SCHEMA  # the first release's table: no requested_error, peer_* ...
            with sqlite3.connect(path) as db:
                db.executescript(old)
                before = {r[1] for r in db.execute("PRAGMA table_info(results)")}
            self.assertFalse(before & {name for name, _ in store.ADDED})
            s = store.Store(path)
            s.insert({"sha256": "x", "parameters": "{}", "path": "p", "outcome": "ok", "message": "", "seconds": 1.0,
                      "tool_version": "v", "finished_at": "t", "peer_triangles": 7})
            self.assertEqual(s.rows()[0]["peer_triangles"], 7)
            s.close()

    def test_sagitta_batch_is_the_issues_name_for_the_api(self):
        import sagitta.batch
        import sagitta_batch

        self.assertIs(sagitta.batch.run, sagitta_batch.run)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_rows(out, count, process, limit=120):
    """Waits until results.sqlite has at least `count` rows (False if the process ends or time runs out)."""
    end = time.monotonic() + limit
    while time.monotonic() < end and process.poll() is None:
        try:
            if len(rows(out)) >= count:
                return True
        except sqlite3.Error:
            pass
        time.sleep(0.2)
    return False


def stable(table):
    """The rows without what legitimately changes between runs (timings, finish time, the path's folder)."""
    drop = {"seconds", "finished_at", "path"}
    return {k: {c: v for c, v in r.items() if c not in drop} for k, r in table.items()}


class Interruptions(unittest.TestCase):
    DELAY = {"SAGITTA_BATCH_TEST_FAULT": ";".join(f"delay:{os.path.basename(n)}" for n in REAL)}

    def test_killed_worker_every_file_recorded_once(self):
        with tempfile.TemporaryDirectory() as tmp:
            corpus = make_corpus(f"{tmp}/corpus", REAL)
            address = f"tcp://127.0.0.1:{free_port()}"
            env = dict(os.environ, **self.DELAY)
            scheduler = subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", address.split(":")[-1],
                                          "--no-dashboard"], env=env, stderr=subprocess.DEVNULL)
            workers = [subprocess.Popen(["dask", "worker", address, "--nthreads", "1", "--no-nanny",
                                         "--no-dashboard"], env=env, stderr=subprocess.DEVNULL) for _ in range(2)]
            try:
                client = subprocess.Popen([SAGITTA, "batch", corpus, "--out", f"{tmp}/out", "--level", "1",
                                           "--scheduler", address], env=env, stdout=subprocess.PIPE,
                                          stderr=subprocess.PIPE, text=True)
                self.assertTrue(wait_rows(f"{tmp}/out", 1, client))
                workers[0].kill()  # mid-batch: the scheduler moves its task to the other worker
                out, err = client.communicate(timeout=300)
                self.assertEqual(client.returncode, 0, err)
                got = rows(f"{tmp}/out")
                self.assertEqual(sorted(got), sorted(os.path.basename(n) for n in REAL))
                self.assertTrue(all(r["outcome"] == "ok" for r in got.values()), got)
                with sqlite3.connect(f"{tmp}/out/results.sqlite") as db:
                    self.assertEqual(db.execute("SELECT count(*) FROM results").fetchone()[0], len(REAL))
            finally:
                for p in workers + [scheduler]:
                    p.kill()
                    p.wait()

    def test_killed_client_resumes_to_the_uninterrupted_result(self):
        with tempfile.TemporaryDirectory() as tmp:
            corpus = make_corpus(f"{tmp}/corpus", REAL)
            args = ["--level", "1", "--workers", "2"]
            whole = batch([corpus, "--out", f"{tmp}/whole", *args], env=self.DELAY)
            self.assertEqual(whole.returncode, 0, whole.stderr)
            client = subprocess.Popen([SAGITTA, "batch", corpus, "--out", f"{tmp}/cut", *args],
                                      env=dict(os.environ, **self.DELAY), start_new_session=True,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            self.assertTrue(wait_rows(f"{tmp}/cut", 2, client))
            os.killpg(client.pid, signal.SIGKILL)  # the client and its local cluster, mid-batch
            client.wait()
            before = len(rows(f"{tmp}/cut"))
            self.assertLess(before, len(REAL))
            resumed = batch([corpus, "--out", f"{tmp}/cut", *args], env=self.DELAY)
            self.assertEqual(resumed.returncode, 0, resumed.stderr)
            self.assertIn(f"{len(REAL) - before} processed now, {before} already done", resumed.stdout)
            self.assertEqual(stable(rows(f"{tmp}/cut")), stable(rows(f"{tmp}/whole")))


if __name__ == "__main__":
    unittest.main()
