"""Smoke test of `sagitta bench --quick`: the JSON has every section and its numbers are positive
and finite. It checks structure only; speed is recorded in docs/BENCHMARKS.md, not tested."""
import json
import math
import subprocess
import sys
import tempfile
import os

sagitta, data = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "bench.json")
    env = dict(os.environ, SAGITTA_SHARED_DATA=data)
    subprocess.run([sagitta, "bench", "--quick", "--json", out], check=True, env=env)
    doc = json.load(open(out))


def positive(x, where):
    assert isinstance(x, (int, float)) and math.isfinite(x) and x > 0, f"{where}: {x!r}"


assert len(doc["bandwidth"]) == 2
for b in doc["bandwidth"]:
    positive(b["memset_bytes_per_s"], "memset")
    positive(b["copy_bytes_per_s"], "copy")
for key in ("single_thread", "all_threads"):
    section = doc["throughput"][key]
    for scheme in ("uniform_grid_float32", "uniform_grid_double", "uniform", "esc", "pn"):
        for field in ("seconds", "triangles", "triangles_per_s", "output_bytes_per_s"):
            positive(section[scheme][field], f"{key}/{scheme}/{field}")
    positive(section["uniform_grid_float32"]["fraction_of_memset"], "fraction")
    positive(section["esc_over_uniform_time_per_triangle"], "esc ratio")
    scene = doc["teacups_scene"][key]
    for scheme in ("uniform", "esc", "uniform_grid_float32", "uniform_grid_float32_prepared"):
        positive(scene[scheme]["per_s"], f"scene/{scheme}")
assert doc["teacups_scene"]["patches"] == 2600
assert len(doc["tea_set"]) == 1
row = doc["tea_set"][0]
assert row["ours"]["certified_error"] <= row["target"]
positive(row["ours"]["validation_over_tessellation"], "validation ratio")
assert row["occt"]["certified_error"] <= row["target"]
positive(row["speedup_single_thread"], "speedup")
positive(row["triangle_ratio"], "triangle ratio")
print("bench JSON ok")
