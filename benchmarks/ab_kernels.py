"""The time step of two trees of the code, alternating, on one built model
(issue 26: "no row more than 3 % slower").

    python benchmarks/ab_kernels.py --before DIR --after DIR --bodies 1e4,2e5 \
        --physics elastic,full --threads 1,2 [--rounds 3] [--seconds 3]

The bench block of `python -m rbsm_dyn bench` (rbsm_dyn/bench.py) is built
once per size and physics by the `before` tree and pickled; then, round
after round, each tree in its own process loads it, takes the same dt,
compiles (not timed), and times `advance(model, state, K)` at each thread
count: best of the rounds, wall and CPU ns per spring-point-step.  The
order of the trees alternates between rounds, so a shared machine's slow
spells hit both alike.  Measures; asserts nothing.

`--side-by-side`: one thread each, the two trees at the same time on
cores 0 and 1 (taskset), swapped every round; the median and range of
the rounds' ratios after/before.  On this VM the one-thread figure of
one tree moved by +-15 % between rounds minutes apart; side by side,
both share a slow spell."""
import argparse
import json
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

CHILD = r'''
import json, pickle, sys, time
import numba
mode, path, threads, seconds = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
from rbsm_dyn.bench import case_text
from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import apply_initial, build_model, new_state
from rbsm_dyn.solvers.explicit import advance, choose_dt, start_half_step
if mode == "build":
    bodies, physics = float(sys.argv[5]), sys.argv[6]
    text = case_text(bodies, physics)
    case = load_case_text(text, "bench.yaml")
    model = build_model(case)
    dt, _ = choose_dt(case, model)
    with open(path, "wb") as f:
        pickle.dump((text, model, dt), f, protocol=5)
    print(json.dumps({"bodies": model.n_bodies, "springs": model.n_springs}))
    sys.exit()
with open(path, "rb") as f:
    text, model, dt = pickle.load(f)
case = load_case_text(text, "bench.yaml")
def fresh():
    st = new_state(model)
    st.dt = dt
    apply_initial(case, model, st)
    start_half_step(model, st)
    return st
out = {}
for nt in map(int, threads.split(",")):
    numba.set_num_threads(nt)
    advance(model, fresh(), 2)                  # compile or cache load, not timed
    st = fresh()
    t0 = time.perf_counter()
    advance(model, st, 2)
    per = max(time.perf_counter() - t0, 1e-6) / 2
    k = max(2, int(seconds / per))
    st = fresh()
    c0, w0 = time.process_time(), time.perf_counter()
    advance(model, st, k)
    w, c = time.perf_counter() - w0, time.process_time() - c0
    S = model.n_springs
    out[nt] = {"steps": k, "wall_ns": w / (S * k) * 1e9, "cpu_ns": c / (S * k) * 1e9}
print(json.dumps(out))
'''


def child(tree, *args, core=None, wait=True):
    env = dict(os.environ, PYTHONPATH=str(tree))
    pin = [] if core is None else ["taskset", "-c", str(core)]
    p = subprocess.Popen([*pin, sys.executable, "-c", CHILD, *map(str, args)], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return finish(p) if wait else p


def finish(p):
    out, err = p.communicate()
    if p.returncode:
        raise RuntimeError(err[-2000:])
    return json.loads(out.strip().splitlines()[-1])


def side_by_side(trees, path, rounds, seconds):
    """Median and range of after/before (wall ns per spring-step, one
    thread each, run at the same time on cores 0 and 1)."""
    for name in trees:                     # compile into each tree's cache first
        child(trees[name], "time", path, "1", 0.1)
    ratios = []
    for r in range(rounds):
        cores = {"before": r % 2, "after": 1 - r % 2}
        procs = {n: child(trees[n], "time", path, "1", seconds, core=cores[n], wait=False)
                 for n in trees}
        res = {n: finish(p)["1"]["wall_ns"] for n, p in procs.items()}
        ratios.append(res["after"] / res["before"])
        print(f"  round {r}: before {res['before']:.1f} after {res['after']:.1f} "
              f"({ratios[-1] - 1:+.1%})", flush=True)
    ratios.sort()
    return ratios[len(ratios) // 2], ratios[0], ratios[-1]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", required=True)
    p.add_argument("--after", required=True)
    p.add_argument("--bodies", default="1e4,2e5")
    p.add_argument("--physics", default="elastic,full")
    p.add_argument("--threads", default="1,2")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--seconds", type=float, default=3.0, help="timed loop per thread count")
    p.add_argument("--work", default="/tmp/ab_kernels")
    p.add_argument("--side-by-side", action="store_true",
                   help="one thread each, both trees at once on cores 0 and 1")
    a = p.parse_args(argv)
    Path(a.work).mkdir(parents=True, exist_ok=True)
    trees = {"before": Path(a.before).resolve(), "after": Path(a.after).resolve()}
    print(f"# ab_kernels {time.strftime('%Y-%m-%d %H:%M')} before={a.before} after={a.after} "
          f"rounds={a.rounds}", flush=True)
    for bodies in a.bodies.split(","):
        for physics in a.physics.split(","):
            path = Path(a.work) / f"model-{bodies}-{physics}.pkl"
            if not path.exists():
                info = child(trees["before"], "build", path, a.threads, a.seconds, bodies, physics)
            else:
                info = {}
            if a.side_by_side:
                med, lo, hi = side_by_side(trees, path, a.rounds, a.seconds)
                print(f"bodies={bodies} {info} physics={physics} threads=1 side by side: "
                      f"after/before median {med - 1:+.1%} (rounds {lo - 1:+.1%} to "
                      f"{hi - 1:+.1%})", flush=True)
                continue
            best = {}
            for r in range(a.rounds):
                order = ("before", "after") if r % 2 == 0 else ("after", "before")
                for name in order:
                    res = child(trees[name], "time", path, a.threads, a.seconds)
                    for nt, v in res.items():
                        b = best.setdefault((name, nt), {"wall_ns": 1e99, "cpu_ns": 1e99})
                        b["wall_ns"] = min(b["wall_ns"], v["wall_ns"])
                        b["cpu_ns"] = min(b["cpu_ns"], v["cpu_ns"])
            for nt in a.threads.split(","):
                bw, aw = best[("before", nt)]["wall_ns"], best[("after", nt)]["wall_ns"]
                bc, ac = best[("before", nt)]["cpu_ns"], best[("after", nt)]["cpu_ns"]
                print(f"bodies={bodies} {info} physics={physics} threads={nt}: wall ns/spring-step "
                      f"before {bw:.1f} after {aw:.1f} ({aw / bw - 1:+.1%}); CPU {bc:.1f} -> "
                      f"{ac:.1f} ({ac / bc - 1:+.1%})", flush=True)


if __name__ == "__main__":
    main()
