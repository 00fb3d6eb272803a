"""Checkpoint and restart of a run with contact (solvers/checkpoint.py,
docs/history.md; issue 30 item 4).  Two rigid blocks thrown onto an
elastic slab, with gravity, friction μ = 0.4 and a contact dashpot: they
land, slide (slip memory), and strike each other (pairs come and go, the
broad phase runs again and again).  The run is killed (SIGKILL) at 20
random moments and continued with --restart: the restarted run must end
in the uninterrupted run's state bit for bit -- every State array and the
contact pairs, slip memory, separating faces and friction work -- and
write the same history."""
import shutil
import textwrap

import numpy as np
import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.solvers.checkpoint import ARRAYS, checkpoint_info, read_checkpoint
from test_restart import _kill_at, _spawn

CASE = """
name: slide-restart
parts:
  slab: {geometry: {box: [[0, 0, 0], [0.06, 0.06, 0.02]]}, mesh: {kind: blocks, divisions: [3, 3, 1]},
         material: c}
  a: {geometry: {box: [[0.005, 0.005, 0.021], [0.025, 0.025, 0.041]]}, mesh: {kind: rigid}, material: c}
  b: {geometry: {box: [[0.035, 0.01, 0.022], [0.055, 0.03, 0.042]]}, mesh: {kind: rigid}, material: c}
materials:
  c: {density: 2400, young: 3.0e10, poisson: 0.2}
boundary: [{surface: slab.zmin, fix: all}]
initial: [{group: a, velocity: [3.0, 0.5, -1.0]}, {group: b, velocity: [-2.0, 1.0, -2.0]}]
contact: {between: all, friction: 0.4, damping: 0.1}
loads: [{gravity: [0, 0, -9.81]}]
solver: {mode: dynamic, end_time: 4.0e-3}
output:
  interval: 1.0e-4
  checkpoint_interval: 5.0e-4
  flush_interval: 0
  fields: [position, orientation, velocity, angular_velocity]
"""

#: (frames to wait for, then a delay [s]): 41 frames in about 0.3 s of run
KILL_POINTS = [(int(k), float(d)) for k, d in zip(
    np.random.default_rng(30).integers(0, 41, 20),
    np.random.default_rng(1030).uniform(0.0, 0.02, 20))]


@pytest.fixture(scope="module")
def ref(tmp_path_factory):
    d = tmp_path_factory.mktemp("restart_contact")
    case = d / "case.yaml"
    case.write_text(textwrap.dedent(CASE), encoding="utf-8")
    out = d / "reference.h5"
    assert main([str(case), "--out", str(out), "--quiet"]) == 0
    return case, out


def assert_same_run(path, ref_path):
    """Final State, contact state and history equal the reference's, bitwise."""
    got, _ = read_checkpoint(path)
    want, _ = read_checkpoint(ref_path)
    for name in ARRAYS + ("step", "dt", "frames", "e0"):
        assert np.array_equal(got[name], want[name]), name
    for name, v in want["contact"].items():
        assert np.array_equal(got["contact"][name], v), name
    h, r = rbsm_dyn.open_history(path), rbsm_dyn.open_history(ref_path)
    assert h.status == "completed"
    assert h.frames == r.frames and np.array_equal(h.time, r.time)
    assert sorted(h.series) == sorted(r.series)
    for p in r.series:
        assert np.array_equal(h.series[p], r.series[p]), p


def test_the_reference_slides_and_strikes(ref):
    """What the restarts must carry is there: the blocks slide on the slab
    (friction work, slip kept in the pairs) and meet each other."""
    case, out = ref
    want, _ = read_checkpoint(out)
    c = want["contact"]
    assert c["builds"] >= 3                          # the broad phase ran again
    assert np.any(np.abs(c["slip"]) > 0)             # slip memory held
    assert c["body_friction"].sum() > 0              # friction worked
    h = rbsm_dyn.open_history(out)
    assert h.observables["contact_friction"][-1] > 0


def test_twenty_random_sigkills_of_a_contact_run_restart_bitwise(ref, tmp_path):
    """SIGKILL at 20 random moments (two runs at a time); each killed run
    is continued with --restart (refused with exit 2 when it holds no
    checkpoint yet, rerun when no file was left) and ends equal to the
    uninterrupted run, bitwise."""
    case, ref_out = ref
    outs = [tmp_path / f"kill{i}.h5" for i in range(len(KILL_POINTS))]
    for i0 in range(0, len(KILL_POINTS), 2):
        batch = range(i0, min(i0 + 2, len(KILL_POINTS)))
        _kill_at([(_spawn(case, outs[i]), outs[i], *KILL_POINTS[i]) for i in batch])
    restarted = 0
    for i, out in enumerate(outs):
        what = f"kill {i} {KILL_POINTS[i]}"
        if not out.exists():
            assert main([str(case), "--out", str(out), "--quiet"]) == 0, what
        elif rbsm_dyn.open_history(out).status != "completed":
            if checkpoint_info(out) is None:
                assert main([str(case), "--restart", str(out), "--quiet"]) == 2, what
                continue
            assert main([str(case), "--restart", str(out), "--quiet"]) == 0, what
            restarted += 1
        assert_same_run(out, ref_out)
    assert restarted >= 8, restarted


def _h5_items(path):
    """{name: (dtype, shape, bytes or value, attributes)} of every group and
    dataset of an HDF5 file."""
    import h5py
    out = {}

    def see(name, obj):
        attrs = {k: np.asarray(v) for k, v in obj.attrs.items()}
        if isinstance(obj, h5py.Dataset):
            v = np.asarray(obj[()])
            data = (v.dtype.str, v.shape, v.tolist() if v.dtype.kind in "OSUV" else v.tobytes())
        else:
            data = None
        out[name] = (data, attrs)
    with h5py.File(str(path), "r") as f:
        see("/", f)
        f.visititems(see)
    return out


def test_restart_with_no_step_left_leaves_the_uninterrupted_runs_file(ref, tmp_path):
    """A run killed after its end-of-run checkpoint but before it set
    status "completed" (its file: the finished one, status "running"):
    --restart has no step left to make and completes the file equal to the
    uninterrupted run's, every dataset bitwise and every attribute -- it
    does not write the end-of-run checkpoint again into the other slot,
    which holds the previous checkpoint, nor flip /checkpoint current
    (benchmarks/restart_cases.py found that on cases/impact_plate.yaml)."""
    import h5py
    case, ref_out = ref
    out = tmp_path / "killed_at_the_end.h5"
    shutil.copy(ref_out, out)
    with h5py.File(out, "r+") as f:
        f.attrs.modify("status", "running")
        assert f["checkpoint"].attrs["current"] in (0, 1)
        assert f["checkpoint/slot0/step"][()] != f["checkpoint/slot1/step"][()]
    assert main([str(case), "--restart", str(out), "--quiet"]) == 0
    got, want = _h5_items(out), _h5_items(ref_out)
    assert sorted(got) == sorted(want)
    for name, (data, attrs) in want.items():
        assert got[name][0] == data, name
        assert sorted(got[name][1]) == sorted(attrs), name
        for k, v in attrs.items():
            assert np.array_equal(got[name][1][k], v), (name, k)
