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
spells hit both alike.  Measures; asserts nothing."""
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


def child(tree, *args):
    env = dict(os.environ, PYTHONPATH=str(tree))
    r = subprocess.run([sys.executable, "-c", CHILD, *map(str, args)], env=env,
                       capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError(r.stderr[-2000:])
    return json.loads(r.stdout.strip().splitlines()[-1])


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
