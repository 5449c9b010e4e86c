#!/usr/bin/env python3
"""host-sim against PythonVehicleSimulator (Fossen's PVS), per simulated second.

Interleaved pairs on one machine; each pair runs, one after the other:
  1. PVS: a fresh `python3` process that imports PVS and calls
     `simulate(15000, 0.02, remus100('depthHeadingAutopilot', 30, 50, 1525, 0.5, 170))`
     (300 s simulated; the REMUS 100 closed-loop depth and heading autopilot of PVS's
     main.py, choice 9). The child reports the CPU and wall time of the `simulate()` call
     alone; the parent measures the whole process (import included).
  2. host-sim whole: `host-sim run lawnmower-3d --out DIR` (its summary, timeseries.csv and
     the PNG figures written), the whole process.
  3. host-sim loop: `host-sim run lawnmower-3d --no-timeseries --no-plots`, the whole
     process (start-up, scenario and summary.json included: an upper bound on the loop).

Figures are CPU seconds (user + system, children included) per simulated second, and wall
seconds; the ratio is PVS / host-sim per simulated second, the median over the pairs. The
simulated time of each host-sim run is read from its summary.json (`simulated_s`).

PVS is not on PyPI: point --pvs-src at its source tree (the folder holding `src/` of
github.com/cybergalactic/PythonVehicleSimulator) or install it so that
`import python_vehicle_simulator` works. It needs numpy and matplotlib. Without it, only
host-sim's side is measured (and said so).

Usage: scripts/bench-pvs.py [--pairs 5] [--pvs-src DIR] [--host-sim PATH] [--json OUT]
"""

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

PVS_N = 15000
PVS_DT = 0.02
PVS_CHILD = f"""
import json, time
from python_vehicle_simulator.lib.mainLoop import simulate
from python_vehicle_simulator.vehicles import remus100
v = remus100('depthHeadingAutopilot', 30, 50, 1525, 0.5, 170)
c0, w0 = time.process_time(), time.perf_counter()
sim_time, sim_data = simulate({PVS_N}, {PVS_DT}, v)
c1, w1 = time.process_time(), time.perf_counter()
assert sim_data.shape[0] == {PVS_N} + 1
print(json.dumps({{"loop_cpu_s": c1 - c0, "loop_wall_s": w1 - w0,
                  "simulated_s": {PVS_N} * {PVS_DT}}}))
"""


def children_cpu_s():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(cmd, env=None):
    """Run cmd to its end; (stdout, CPU s of the process, wall s)."""
    c0, w0 = children_cpu_s(), time.perf_counter()
    p = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    w1, c1 = time.perf_counter(), children_cpu_s()
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} exited {p.returncode}:\n{p.stderr[-2000:]}")
    return p.stdout, c1 - c0, w1 - w0


def pvs_env(pvs_src):
    env = dict(os.environ)
    if pvs_src:
        src = os.path.join(pvs_src, "src")
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    # One thread per process, as host-sim's run (numpy's BLAS would otherwise spread).
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[k] = "1"
    return env


def pvs_available(env):
    p = subprocess.run(
        [sys.executable, "-c", "import python_vehicle_simulator.lib.mainLoop"],
        env=env,
        capture_output=True,
        text=True,
    )
    return p.returncode == 0, p.stderr.strip().splitlines()[-1:] if p.returncode else []


def host_sim_run(exe, out_dir, extra):
    shutil.rmtree(out_dir, ignore_errors=True)
    _, cpu, wall = timed([exe, "run", "lawnmower-3d", "--out", out_dir, *extra])
    with open(os.path.join(out_dir, "summary.json")) as f:
        s = json.load(f)
    written = sorted(os.listdir(out_dir))
    return {"cpu_s": cpu, "wall_s": wall, "simulated_s": s["simulated_s"], "files": written}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--pvs-src", help="PVS source tree (the folder with src/)")
    ap.add_argument(
        "--host-sim",
        default=os.path.join(os.path.dirname(__file__), "..", "target", "release", "host-sim"),
        help="host-sim binary (default target/release/host-sim; build it with "
        "`cargo build -p host-sim --release`)",
    )
    ap.add_argument("--json", help="write the pairs and medians here")
    a = ap.parse_args()
    exe = os.path.abspath(a.host_sim)
    if not os.access(exe, os.X_OK):
        sys.exit(f"no host-sim binary at {exe}: cargo build -p host-sim --release")
    env = pvs_env(a.pvs_src)
    have_pvs, why = pvs_available(env)
    if not have_pvs:
        print(
            f"PVS not importable ({' '.join(why)}): measuring host-sim only. Give --pvs-src "
            "DIR (PVS's source tree, with src/) for the comparison.",
            file=sys.stderr,
        )
    tmp = tempfile.mkdtemp(prefix="bench-pvs-")
    pairs = []
    try:
        for i in range(a.pairs):
            row = {}
            if have_pvs:
                out, cpu, wall = timed([sys.executable, "-c", PVS_CHILD], env=env)
                child = json.loads(out.strip().splitlines()[-1])
                row["pvs"] = {"cpu_s": cpu, "wall_s": wall, **child}
            row["whole"] = host_sim_run(exe, os.path.join(tmp, "whole"), [])
            row["loop"] = host_sim_run(
                exe, os.path.join(tmp, "loop"), ["--no-timeseries", "--no-plots"]
            )
            pairs.append(row)
            print(f"pair {i + 1}/{a.pairs}: " + line(row), flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    med = medians(pairs, have_pvs)
    print()
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the end")
    print("median per simulated second (ms):")
    for k, v in med["per_sim_s_ms"].items():
        print(f"  {k:<28} {v:9.3f}")
    if have_pvs:
        print("median ratio PVS / host-sim (per simulated second):")
        for k, v in med["ratios"].items():
            print(f"  {k:<28} {v:7.1f}x")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"pairs": pairs, "medians": med}, f, indent=2)
            f.write("\n")


def per_s(r, key):
    return r[key] / r["simulated_s"]


def line(row):
    parts = []
    if "pvs" in row:
        p = row["pvs"]
        parts.append(
            f"PVS simulate() {p['loop_cpu_s']:.2f} s CPU, process {p['cpu_s']:.2f} s CPU "
            f"{p['wall_s']:.2f} s wall"
        )
    w, l = row["whole"], row["loop"]
    parts.append(f"host-sim whole {w['cpu_s']:.3f} s CPU {w['wall_s']:.3f} s wall ({len(w['files'])} files)")
    parts.append(f"loop {l['cpu_s']:.3f} s CPU {l['wall_s']:.3f} s wall")
    return "; ".join(parts)


def medians(pairs, have_pvs):
    m = statistics.median
    out = {"per_sim_s_ms": {}, "ratios": {}}
    series = {
        "host-sim whole, CPU": [1e3 * per_s(r["whole"], "cpu_s") for r in pairs],
        "host-sim whole, wall": [1e3 * per_s(r["whole"], "wall_s") for r in pairs],
        "host-sim loop, CPU": [1e3 * per_s(r["loop"], "cpu_s") for r in pairs],
        "host-sim loop, wall": [1e3 * per_s(r["loop"], "wall_s") for r in pairs],
    }
    if have_pvs:
        series["PVS simulate(), CPU"] = [
            1e3 * r["pvs"]["loop_cpu_s"] / r["pvs"]["simulated_s"] for r in pairs
        ]
        series["PVS simulate(), wall"] = [
            1e3 * r["pvs"]["loop_wall_s"] / r["pvs"]["simulated_s"] for r in pairs
        ]
        series["PVS process, CPU"] = [1e3 * per_s(r["pvs"], "cpu_s") for r in pairs]

        def ratio(pvs, ours):
            return m(
                [
                    (r["pvs"][pvs] / r["pvs"]["simulated_s"]) / per_s(r[ours[0]], ours[1])
                    for r in pairs
                ]
            )

        out["ratios"] = {
            "whole, CPU": ratio("loop_cpu_s", ("whole", "cpu_s")),
            "whole, wall": ratio("loop_wall_s", ("whole", "wall_s")),
            "loop, CPU": ratio("loop_cpu_s", ("loop", "cpu_s")),
            "loop, wall": ratio("loop_wall_s", ("loop", "wall_s")),
        }
    out["per_sim_s_ms"] = {k: m(v) for k, v in series.items()}
    return out


if __name__ == "__main__":
    main()
