"""dt_safety sweep of the shipped dynamic cases (issue 14): is every case
stable at every allowed solver.dt_safety?

    NUMBA_NUM_THREADS=1 python benchmarks/dt_sweep.py CASE [SAFETY,...] [--max-steps N]
    NUMBA_NUM_THREADS=1 python benchmarks/dt_sweep.py impulsive_beam 0.8,0.85

Runs cases/CASE.yaml through the command line (1 thread) at each
dt_safety (default 0.8, case.DT_SAFETY_MAX), in a temporary folder, and
prints one JSON line per run: exit code, steps, the largest |balance error|
over the frames as a share of the largest supplied energy, the largest
(held + dissipated) / supplied (what the divergence guard bounds by 1.5),
and the last line of stderr.  A value above case.DT_SAFETY_MAX is refused
by the case check (exit 2).  Results: benchmarks/results/stability.md (e).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from ruamel.yaml import YAML

import rbsm_dyn
from rbsm_dyn.case import DT_SAFETY_MAX

ROOT = Path(__file__).resolve().parents[1]


def run(case, safety, folder, max_steps=None):
    y = YAML(typ="rt")
    data = y.load((ROOT / "cases" / f"{case}.yaml").read_text(encoding="utf-8"))
    data["solver"]["dt_safety"] = safety
    path = Path(folder) / f"{case}_{safety}.yaml"
    out = Path(folder) / f"{case}_{safety}.h5"
    with open(path, "w", encoding="utf-8") as f:
        y.dump(data, f)
    args = [sys.executable, "-m", "rbsm_dyn", str(path), "--out", str(out), "--quiet",
            "--threads", "1"] + (["--max-steps", str(max_steps)] if max_steps else [])
    t0 = time.perf_counter()
    r = subprocess.run(args, env=dict(os.environ, NUMBA_NUM_THREADS="1"), capture_output=True,
                       text=True)
    res = dict(case=case, safety=safety, code=r.returncode,
               wall=round(time.perf_counter() - t0, 1),
               err=r.stderr.strip().splitlines()[-1] if r.stderr.strip() else "")
    if out.exists():
        h = rbsm_dyn.open_history(out)
        eb = h.energy_balance()
        sup = float(np.abs(eb["supplied"]).max())
        o = h.observables
        total = sum(o[k] for k in ("kinetic", "strain", "plastic", "fracture", "damping")
                    if k in o)
        res.update(steps=int(h.step[-1]), t_end=float(h.time[-1]), status=h.status,
                   max_error=float(np.abs(eb["error"]).max() / sup),
                   max_ratio=float(np.max(total / np.maximum(np.abs(eb["supplied"]), 1e-300))))
    return res


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case")
    p.add_argument("safety", nargs="?", default=f"0.8,{DT_SAFETY_MAX}")
    p.add_argument("--max-steps", type=int)
    a = p.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        for s in map(float, a.safety.split(",")):
            print(json.dumps(run(a.case, s, folder, a.max_steps)), flush=True)


if __name__ == "__main__":
    main()
