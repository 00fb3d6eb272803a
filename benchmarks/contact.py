"""Cost of contact between cells on a fragmenting model (issue 16): a
Voronoi glass cube thrown at 30 m/s onto the ground shatters; the same run
with and without the case key ``contact`` (and the ground, which needs it),
loop time apart from the build.

    python benchmarks/contact.py --cells 5000 --steps 400 [--threads 1]

Prints one Markdown row per size: ns per spring-point-step of the run
without contact, and with contact the extra cost per body-step, the broad
phase's share (rebuilds and their mean time) and the candidate pairs per
body.  Results in benchmarks/results/contact.md.
"""
import argparse
import time

import numpy as np

CASE = """\
name: shatter
domain: {{box: [[0, 0, 0.001], [{L}, {L}, {Lz}]]}}
mesh: {{kind: voronoi, size: {size:.6g}, seed: 1}}
materials:
  glass: {{density: 2500, young: 7.0e10, poisson: 0.2,
          rupture: {{fracture_energy: 8.0, tensile_strength: 4.0e7}}, friction: 0.3}}
initial: [{{velocity: [0, 0, -30]}}]
{contact}
solver: {{mode: dynamic, end_time: 1.0}}
"""
CONTACT = ("contact: {between: all, friction: 0.3, "
           "ground: {point: [0, 0, 0], normal: [0, 0, 1]}}")


def run(cells, steps, contact):
    from rbsm_dyn.model import contact as cmod
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import apply_initial, build_model, new_state
    from rbsm_dyn.solvers.explicit import advance, choose_dt, start_half_step
    L = 0.1
    size = L / cells ** (1.0 / 3.0)
    text = CASE.format(L=L, Lz=L + 0.001, size=size, contact=CONTACT if contact else "")
    case = load_case_text(text)
    model = build_model(case)
    st = new_state(model)
    dt, est = choose_dt(case, model)
    st.dt = dt
    apply_initial(case, model, st)
    if contact:
        cmod.rebuild(model, st, force=True)
    start_half_step(model, st)
    advance(model, st, 1)                      # compiled, warm
    t_broad = 0.0
    builds = 0
    pairs = 0
    t0 = time.perf_counter()
    done = 0
    while done < steps:
        n = steps - done
        if contact:
            tb = time.perf_counter()
            if cmod.rebuild(model, st):
                builds += 1
            t_broad += time.perf_counter() - tb
            n = min(n, cmod.chunk_steps(model, st, dt, model.gravity))
            pairs += len(st.contact.pairs) * n
        advance(model, st, n)
        done += n
    wall = time.perf_counter() - t0
    broken = int(np.count_nonzero(st.spring_state >= 2)) / max(model.n_springs, 1)
    return dict(n=model.n_bodies, s=model.n_springs, wall=wall, broad=t_broad, builds=builds,
                pairs=pairs / steps, broken=broken)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", default="1000,5000")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    import numba
    numba.set_num_threads(a.threads)
    print("| cells | spring points | steps | broken at end | without contact ns/spring-step "
          "| with contact: extra µs/body-step | broad phase share | rebuilds | pairs/body |")
    print("|---|---|---|---|---|---|---|---|---|")
    for c in (int(float(x)) for x in a.cells.split(",")):
        off = run(c, a.steps, False)
        on = run(c, a.steps, True)
        extra = (on["wall"] - off["wall"]) / (on["n"] * a.steps) * 1e6
        print(f"| {on['n']} | {on['s']} | {a.steps} | {100 * on['broken']:.0f} % "
              f"| {off['wall'] / (off['s'] * a.steps) * 1e9:.1f} "
              f"| {extra:.2f} | {on['broad'] / max(on['wall'] - off['wall'], 1e-12):.0%} "
              f"| {on['builds']} | {on['pairs'] / on['n']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
