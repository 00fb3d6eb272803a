"""Cost of a plane model's viscous springs on the plane passes against the
slab's 3D passes (issue 27): tests/test_plane.py's VISCOUS cantilever (a
standard linear solid, Rayleigh's β) at the cell size given (default 2 mm:
5 000 cells), the best of 3 timings of 200 steps after 20, alternated.

    NUMBA_NUM_THREADS=1 python benchmarks/plane_viscous.py 0.002
"""
import sys
import time
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "tests"))
from test_plane import VISCOUS  # noqa: E402
import rbsm_dyn.solvers.explicit as ex  # noqa: E402
from rbsm_dyn.case import load_case_text  # noqa: E402
from rbsm_dyn.model import apply_initial, build_model, new_state  # noqa: E402
size = sys.argv[1] if len(sys.argv) > 1 else "0.002"
case = load_case_text(VISCOUS.replace("size: 0.01", f"size: {size}"))
m = build_model(case)
dt = 0.8 * m.stable_dt()
print("bodies", m.n_bodies, "springs", m.n_springs)
real = ex.plane_ready
for label, ready in [("plane", real), ("slab", lambda *a: False), ("plane", real), ("slab", lambda *a: False)]:
    ex.plane_ready = ready
    st = new_state(m); st.dt = dt; apply_initial(case, m, st); ex.start_half_step(m, st)
    ex.advance(m, st, 20)
    best = 1e9
    for r in range(3):
        t = time.perf_counter(); ex.advance(m, st, 200); best = min(best, time.perf_counter() - t)
    print(label, f"{best / 200 * 1e3:.3f} ms/step")
