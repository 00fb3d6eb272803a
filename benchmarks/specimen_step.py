"""Time the fracture calibration's notched tension specimen (2 mm cells,
ν = 0.2, the mixed-mode law, fracture_calibration.tension_specimen) run to
its end on one thread: the run of tests/test_fracture_calibration.py, most
of whose springs stay elastic while a crack crosses the ligament.

    NUMBA_NUM_THREADS=1 python benchmarks/specimen_step.py [--repeat 3]

Compare two trees in alternation by PYTHONPATH (each with its own
NUMBA_CACHE_DIR); results: benchmarks/results/mixed_law.md."""
import argparse
import os
import tempfile
import time

from rbsm_dyn.__main__ import main
from rbsm_dyn.fracture_calibration import tension_specimen


def run():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=20)
    a = ap.parse_args()
    text, _, _ = tension_specimen(cell=0.002, cells_across=8, notch=0.5, young=30e9,
                                  tensile_strength=3e6, fracture_energy=4.8, poisson=0.2,
                                  seed=a.seed, ramps=2, frames=12)
    d = tempfile.mkdtemp()
    case = os.path.join(d, "specimen.yaml")
    with open(case, "w", encoding="utf-8") as f:
        f.write(text)
    # compile or load the kernels first
    main([case, "--out", os.path.join(d, "warm.h5"), "--quiet", "--max-steps", "50"])
    times = []
    for r in range(a.repeat):
        t = time.perf_counter()
        assert main([case, "--out", os.path.join(d, f"run{r}.h5"), "--quiet"]) == 0
        times.append(time.perf_counter() - t)
    print("specimen run [s]:", " ".join(f"{x:.2f}" for x in times))


if __name__ == "__main__":
    run()
