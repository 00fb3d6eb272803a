"""Strong scaling of the distributed explicit run (solvers/distributed.py).

    mpirun -n P python benchmarks/mpi_scaling.py --bodies 36000 --steps 60 --physics elastic

Builds bench's Voronoi block (rbsm_dyn/bench.py) on rank 0, then times
K steps of the explicit loop two ways on the same model and start:

* one process, one thread (`advance`: the one-process baseline);
* P processes through `Leader.advance` (one thread a rank), the ghosts
  traded after every step;

and prints one line with the decomposition's figures (spring points
computed twice, the largest rank's share over the mean, ghosts), the
bytes exchanged per step, the time per step of each, the efficiency
t_1 / (P t_P), and whether the P-process state equals the one-process
state bit for bit.  Run with P = 1 it times the one-process loop only.
`--method metis` decomposes by METIS instead of coordinate bisection.
"""
import argparse
import os
import time

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bodies", type=float, default=36000)
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--physics", default="elastic")
    ap.add_argument("--method", default="rcb")
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    from rbsm_dyn.mpi_env import rank_threads, world
    os.environ.setdefault("NUMBA_NUM_THREADS", str(rank_threads()))
    comm = world()
    if comm is not None and comm.rank > 0:
        from rbsm_dyn.solvers.distributed import worker
        worker(comm)
        return
    from rbsm_dyn.bench import case_text
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import apply_initial, build_model, new_state
    from rbsm_dyn.solvers.explicit import advance, choose_dt, start_half_step
    case = load_case_text(case_text(int(a.bodies), a.physics), "bench.yaml")
    model = build_model(case)

    def fresh():
        st = new_state(model)
        st.dt, _ = choose_dt(case, model)
        apply_initial(case, model, st)
        start_half_step(model, st)
        return st

    def timed(step_fn):
        best, st = np.inf, None
        for _ in range(a.rounds):
            st = fresh()
            t0 = time.perf_counter()
            step_fn(model, st, a.steps)
            best = min(best, time.perf_counter() - t0)
        return best / a.steps, st

    advance(model, fresh(), 1)                     # compile or load
    t1, ref = timed(advance)
    P = 1 if comm is None else comm.size
    line = (f"mpi: bodies={model.n_bodies} springs={model.n_springs} physics={a.physics} "
            f"P=1 ms_per_step={t1 * 1e3:.2f}")
    if comm is not None:
        from rbsm_dyn.solvers.distributed import GHOST_WIDTH, Leader
        leader = Leader(comm, a.method)
        leader.advance(model, fresh(), 1)          # setup, compile or load
        leader.seconds(reset=True)
        tp, st = timed(leader.advance)
        split = leader.seconds()
        t_x = leader.exchange_seconds(200)
        f = leader.figures
        same = all(np.array_equal(getattr(ref, k), getattr(st, k)) for k in
                   ("body_pos", "body_quat", "body_vel", "body_angmom", "body_work"))
        line += (f" P={P} method={f['method']} ms_per_step={tp * 1e3:.2f} "
                 f"efficiency={t1 / (P * tp):.2f} duplicated={f['duplicated']:.3f} "
                 f"imbalance={f['imbalance']:.3f} ghosts_max={f['ghosts_max']} "
                 f"bytes_per_step={f['exchanged'] * GHOST_WIDTH * 8} "
                 f"exchange_us={t_x * 1e6:.0f} step_exchange_s_per_rank={split} bitwise={'yes' if same else 'NO'}")
        from rbsm_dyn.solvers.distributed import stop_workers
        stop_workers(comm, 0)
    print(line, flush=True)


if __name__ == "__main__":
    main()
