"""Cost of a plane model's step against its one-cell 3D slab (issue 27).

The same block plate, n × n blocks of 1 cm, 1 cm thick, clamped on one
edge and pulled at the other, built as a plane model (plane passes,
physics/plane.py) and as the 3D slab held in z, rx, ry (3D passes): the
best of `--repeat` timings of `--steps` explicit steps after a warm-up, in
ns per body-step, at 1 and 2 threads.

    python benchmarks/plane_vs_slab.py --n 200 --steps 200
"""
import argparse
import time

import numba
import numpy as np

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_model, new_state
from rbsm_dyn.solvers import explicit


def case(n, plane):
    L = 0.01 * n
    if plane:
        geo = f"plane: {{kind: stress, thickness: 0.01}}\ndomain: {{box: [[0, 0], [{L}, {L}]]}}\n" \
              f"mesh: {{kind: blocks, divisions: [{n}, {n}]}}\n"
        extra = ""
        vel = "[1.0, 0]"
    else:
        geo = f"domain: {{box: [[0, 0, -0.005], [{L}, {L}, 0.005]]}}\n" \
              f"mesh: {{kind: blocks, divisions: [{n}, {n}, 1]}}\n"
        extra = ", {group: every, fix: [z, rx, ry]}"
        vel = "[1.0, 0, 0]"
    box = "[[-1, -1, -1], [100, 100, 1]]" if not plane else "[[-1, -1], [100, 100]]"
    pull = f"[[{L - 0.01}, -1, -1], [100, 100, 1]]" if not plane else f"[[{L - 0.01}, -1], [100, 100]]"
    return f"""
name: bench
{geo}materials: {{steel: {{density: 7800, young: 200.0e9, poisson: 0.3}}}}
groups: {{every: {{box: {box}}}, pull: {{box: {pull}}}}}
boundary: [{{face: xmin, fix: all}}, {{group: pull, velocity: {vel}}}{extra}]
solver: {{mode: dynamic, end_time: 1.0}}
"""


def timing(model, steps, repeat):
    state = new_state(model)
    state.dt = 0.5 * model.stable_dt()
    explicit.advance(model, state, 2)                  # compile / warm
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        explicit.advance(model, state, steps)
        best = min(best, time.perf_counter() - t0)
    return best / steps / model.n_bodies * 1e9


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    models = {k: build_model(load_case_text(case(a.n, k == "plane"))) for k in ("plane", "slab")}
    for k, m in models.items():
        print(f"{k}: {m.n_bodies} bodies, {m.n_springs} spring points")
    print("threads  plane ns/body-step  slab ns/body-step  ratio")
    for th in (1, 2):
        numba.set_num_threads(th)
        t = {k: timing(m, a.steps, a.repeat) for k, m in models.items()}
        print(f"{th:7d}  {t['plane']:18.1f}  {t['slab']:17.1f}  {t['plane'] / t['slab']:.3f}")


if __name__ == "__main__":
    main()
