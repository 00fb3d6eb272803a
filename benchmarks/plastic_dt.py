"""The impulsive beam at a fixed step above the 0.85 cap (issue 30 item 6:
why plasticity diverges below the elastic stable step).

    python benchmarks/plastic_dt.py CRITERION DT [V0]
    python benchmarks/plastic_dt.py normal 2.2e-7 4.43

Runs cases/impulsive_beam.yaml in the current folder with yield
`criterion` CRITERION, `solver.dt` DT [s] (the case check's cap on dt,
explicit.DT_SAFETY_MAX, lifted in this process) and the initial velocity
V0 [m/s] (default the case's 14), and prints the exit code, the frames,
the largest |energy balance error| as a share of the largest supplied
energy and the deepest midspan deflection.  The exact elastic step of the
case is 2.939e-7 s (`info`, Lanczos).  Measures; asserts nothing.
Results: benchmarks/results/stability.md (f) (the step now follows the
bound of the deformed state; before, the runs above 0.57 of the exact
step diverged)."""
import sys
from pathlib import Path

import numpy as np

import rbsm_dyn
import rbsm_dyn.solvers.explicit as explicit
from rbsm_dyn.__main__ import main

CASE = Path(__file__).resolve().parent.parent / "cases" / "impulsive_beam.yaml"
EXACT_DT = 2.939e-7


def run(criterion, dt, v0="14.0"):
    explicit.DT_SAFETY_MAX = 5.0
    text = (CASE.read_text()
            .replace("solver: {mode: dynamic, end_time: 3.0e-3}",
                     f"solver: {{mode: dynamic, end_time: 3.0e-3, dt: {dt}}}")
            .replace("criterion: von_mises", f"criterion: {criterion}")
            .replace("velocity: [0, 0, -14.0]", f"velocity: [0, 0, -{v0}]"))
    stem = f"plastic_dt_{criterion}_{dt}_{v0}"
    Path(f"{stem}.yaml").write_text(text)
    rc = main([f"{stem}.yaml", "--out", f"{stem}.h5", "--quiet"])
    h = rbsm_dyn.open_history(f"{stem}.h5")
    e = h.energy_balance()
    err = np.abs(e["error"]).max() / np.abs(e["supplied"]).max()
    print(f"{criterion} dt={dt} ({float(dt) / EXACT_DT:.2f} of the exact step) V0={v0} "
          f"exit={rc} frames={h.frames} balance={err:.3g} "
          f"deflection={-np.min(h.observables['mid_z']):.4g} m")


if __name__ == "__main__":
    run(*sys.argv[1:])
