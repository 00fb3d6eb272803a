"""Plane contact pass against the slab's 3D contact pass (issue 27).

A plane Voronoi disc (radius 50 mm, 10 mm thick, cells of `--size`)
thrown at a rough ground at 20 m/s: it shatters and its fragments strike
the ground and each other (tests/test_plane_contact.py DISC, larger).
Two figures, plane passes against the slab's 3D passes (solvers/plane.py
plane_ready forced off):

* the contact pass alone, ms per step, the best of `--repeat` × 50 calls
  on the state at `--at` seconds (on copies of the contact state);
* a whole run to `--end`, s (broad phase, output frames, Python between
  chunks included; the first run of each warms the kernels).

    python benchmarks/plane_contact.py --size 0.0015 --threads 1
"""
import argparse
import time

import numba
import numpy as np

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import apply_initial, build_model, new_state
from rbsm_dyn.model.contact import chunk_steps, rebuild
from rbsm_dyn.solvers import explicit

DISC = """
name: disc-drop
plane: {{kind: stress, thickness: 0.01}}
domain: {{circle: {{center: [0.0, 0.06], radius: 0.05}}}}
mesh: {{kind: voronoi, size: {size}, seed: 3}}
materials:
  c: {{density: 2400, young: 30.0e9, poisson: 0.2,
      rupture: {{tensile_strength: 3.0e6, fracture_energy: 20.0}}}}
initial: [{{group: all, velocity: [3.0, -20.0]}}]
contact: {{between: all, friction: 0.5, damping: 0.1,
          ground: {{point: [0, 0.0095], normal: [0, 1]}}}}
solver: {{mode: dynamic, end_time: 1.0}}
"""


def run_to(case, model, t_end):
    state = new_state(model)
    state.dt = 0.8 * model.stable_dt()
    apply_initial(case, model, state)
    explicit.start_half_step(model, state)
    n = int(t_end / state.dt)
    while state.step < n:
        rebuild(model, state)
        explicit.advance(model, state, min(n - state.step,
                                           chunk_steps(model, state, state.dt, model.gravity)))
    return state


def pass_ms(model, state, repeat, plane):
    from rbsm_dyn.physics.collide import contact_step
    from rbsm_dyn.physics.plane_contact import plane_contact_step
    from rbsm_dyn.solvers.passes import body_state, contact_arrays, model_arrays
    from rbsm_dyn.solvers.plane import plane_arrays, plane_contact_arrays, plane_state
    rebuild(model, state, force=True)
    cs = state.contact.trial()
    if plane:
        state.plane = None
        args = (plane_contact_arrays(model, cs), plane_arrays(model)[0],
                plane_state(model, state), 0.0)
        f = plane_contact_step
    else:
        args = (contact_arrays(model, cs), model_arrays(model)[0], body_state(state), 0.0, True)
        f = contact_step
    f(*args)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(50):
            f(*args)
        best = min(best, (time.perf_counter() - t0) / 50)
    return 1e3 * best, len(cs.pairs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=0.0015)
    ap.add_argument("--at", type=float, default=1.5e-4)
    ap.add_argument("--end", type=float, default=3.0e-4)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    numba.set_num_threads(a.threads)
    case = load_case_text(DISC.format(size=a.size))
    model = build_model(case)
    print(f"{model.n_bodies} cells, {model.n_springs} spring points, {a.threads} thread(s)")
    rows = []
    for plane in (True, False):
        if not plane:
            explicit.plane_ready = lambda *args: False
        state = run_to(case, model, a.at)
        ms, pairs = pass_ms(model, state, a.repeat, plane)
        walls = []
        for _ in range(2):
            t0 = time.perf_counter()
            run_to(case, model, a.end)
            walls.append(time.perf_counter() - t0)
        rows.append(("plane" if plane else "slab (3D)", ms, pairs, walls[-1]))
    print("| passes | contact pass [ms/step] | pairs | run to "
          f"{a.end * 1e6:g} µs [s] |\n|---|---|---|---|")
    for name, ms, pairs, wall in rows:
        print(f"| {name} | {ms:.3f} | {pairs} | {wall:.2f} |")


if __name__ == "__main__":
    main()
