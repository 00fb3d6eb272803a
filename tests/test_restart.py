"""Checkpoint and restart (solvers/checkpoint.py, docs/history.md).

An inelastic case (a glass cube thrown at 300 m/s onto a support that can
break: springs rupture, cracks open and close in frictional contact) runs
once without interruption (the reference); other runs of it are killed
(SIGKILL) or stopped (SIGTERM, SIGINT) part-way in a subprocess and then
continued with --restart.  The continued run must end in the reference's
state bit for bit -- every State array, spring history included -- and
write the same history."""
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.solvers.checkpoint import ARRAYS, checkpoint_info, read_checkpoint

CASE = """
name: shatter-restart
domain: {box: [[0, 0, 0], [0.04, 0.04, 0.04]]}
mesh: {kind: blocks, divisions: [4, 4, 4]}
materials:
  glass: {density: 2500, young: 60.0e9, poisson: 0.0, rupture: {strain: 1.0e-3}, friction: 0.3}
boundary: [{face: zmin, fix: all, breakable: true}]
initial: [{velocity: [20.0, 0, -300.0]}]
solver: {mode: dynamic, end_time: 8.0e-4}
output:
  interval: 2.0e-5
  checkpoint_interval: 1.0e-4
  flush_interval: 0          # every frame on disk at once: the kill lands after one
  fields: [position, orientation, velocity, angular_velocity, spring_state]
"""
WAIT = 300.0        # s: give up on a subprocess that shows no progress (a slow, shared machine)


@pytest.fixture(scope="module")
def ref(tmp_path_factory):
    """The case file and its uninterrupted run."""
    d = tmp_path_factory.mktemp("restart")
    case = d / "case.yaml"
    case.write_text(textwrap.dedent(CASE), encoding="utf-8")
    out = d / "reference.h5"
    assert main([str(case), "--out", str(out), "--quiet"]) == 0
    return case, out


def _spawn(case, out):
    env = dict(os.environ, NUMBA_NUM_THREADS=os.environ.get("NUMBA_NUM_THREADS", "1"))
    env.pop("RBSM_PROGRESS", None)
    return subprocess.Popen([sys.executable, "-m", "rbsm_dyn", str(case), "--out", str(out),
                             "--quiet"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _frames(out):
    try:
        with h5py.File(str(out), "r", swmr=True) as f:
            return int(f.attrs["frames"])
    except (OSError, KeyError):
        return 0


def _info(out):
    try:
        return checkpoint_info(out)
    except (OSError, KeyError):
        return None


def _wait_for(proc, condition, what):
    t0 = time.monotonic()
    while not condition():
        if proc.poll() is not None:
            raise AssertionError(f"the run ended (exit {proc.returncode}) before {what}:\n"
                                 f"{proc.stderr.read()}")
        if time.monotonic() - t0 > WAIT:
            proc.kill()
            proc.wait()
            raise AssertionError(f"no {what} after {WAIT:g} s")
        time.sleep(0.01)


def assert_same_run(path, ref_path):
    """Final State (the end-of-run checkpoint) and the whole history equal
    the reference's, bitwise."""
    got, _ = read_checkpoint(path)
    want, _ = read_checkpoint(ref_path)
    for name in ARRAYS + ("step", "dt", "frames", "e0"):
        assert np.array_equal(got[name], want[name]), name
    assert want["spring_state"].max() >= 2          # cracks formed: history arrays matter
    assert np.any(want["spring_dmg"] > 0) or np.any(want["spring_wf"] > 0)
    h, r = rbsm_dyn.open_history(path), rbsm_dyn.open_history(ref_path)
    assert h.status == "completed"
    assert h.frames == r.frames
    assert np.array_equal(h.step, r.step) and np.array_equal(h.time, r.time)
    assert sorted(h.series) == sorted(r.series)
    for p in r.series:
        assert np.array_equal(h.series[p], r.series[p]), p
        assert np.array_equal(h.series_step[p], r.series_step[p]), p


def test_sigkill_mid_run_then_restart_is_bitwise(ref, tmp_path):
    """SIGKILL once a checkpoint exists and at least one frame was written
    after it: the file stays readable (its counted frames are finite and
    equal the reference's), and --restart completes the run with the
    reference's final state and history, bitwise."""
    case, ref_out = ref
    out = tmp_path / "killed.h5"
    proc = _spawn(case, out)

    def checkpoint_and_a_frame_after_it():
        info = _info(out)
        return info is not None and _frames(out) > info[2]

    _wait_for(proc, checkpoint_and_a_frame_after_it, "a checkpoint followed by a frame")
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate()
    assert proc.returncode == -signal.SIGKILL
    step, t, ck_frames = checkpoint_info(out)
    r = rbsm_dyn.open_history(ref_out)
    assert 0 < step < r.step[-1]                     # killed in the middle

    h = rbsm_dyn.open_history(out)
    assert h.status == "running"
    assert ck_frames < h.frames < r.frames
    for p, v in h.series.items():
        assert len(v) == h.frames
        assert np.all(np.isfinite(v)), p
        assert np.array_equal(v, r.series[p][:h.frames]), p
    assert np.array_equal(h.time, r.time[:h.frames])

    assert main([str(case), "--restart", str(out), "--quiet"]) == 0
    assert_same_run(out, ref_out)


#: kill points of test_twenty_random_sigkills: (frames to wait for, then a
#: delay [s]), drawn once from a fixed seed (a frame every ~15 ms of a run of
#: ~0.6 s after ~3 s of start-up; frame 0 waits for nothing: the kill lands
#: in the start-up or the build)
KILL_POINTS = [(int(k), float(d)) for k, d in zip(
    np.random.default_rng(14).integers(0, 42, 20),
    np.random.default_rng(1014).uniform(0.0, 0.03, 20))]


def _kill_at(procs):
    """SIGKILL each (proc, out, frames k, delay) once its file holds k
    frames (k = 0: at once) and the delay has passed; the runs go on side by
    side meanwhile."""
    due = {}
    t0 = time.monotonic()
    left = list(range(len(procs)))
    while left:
        now = time.monotonic()
        for j in list(left):
            proc, out, k, delay = procs[j]
            if j not in due and (k == 0 or proc.poll() is not None or _frames(out) >= k):
                due[j] = now + delay
            if j in due and now >= due[j]:
                os.kill(proc.pid, signal.SIGKILL)
                proc.communicate()
                left.remove(j)
        if now - t0 > WAIT:
            for j in left:
                procs[j][0].kill()
            raise AssertionError(f"no progress after {WAIT:g} s")
        time.sleep(0.001)


def test_twenty_random_sigkills_leave_a_readable_file_and_a_bitwise_restart(ref, tmp_path):
    """SIGKILL at 20 random moments (KILL_POINTS: from the start-up to
    after the end, inside frame and checkpoint writes where they fall; two
    runs at a time).  Each time the output is either absent (killed before
    its first frame: only the staged .tmp file, which a new run replaces)
    or a readable history whose frames equal the reference's; --restart
    then continues from its last checkpoint to the reference's final state
    and history bit for bit, or is refused with exit 2 when there is no
    checkpoint yet, or the run had completed (equal to the reference)."""
    case, ref_out = ref
    r = rbsm_dyn.open_history(ref_out)
    seen = {"absent": 0, "no checkpoint": 0, "restarted": 0, "completed": 0}
    outs = [tmp_path / f"kill{i}.h5" for i in range(len(KILL_POINTS))]
    for i0 in range(0, len(KILL_POINTS), 2):
        batch = range(i0, min(i0 + 2, len(KILL_POINTS)))
        _kill_at([(_spawn(case, outs[i]), outs[i], *KILL_POINTS[i]) for i in batch])
    for i, (k, delay) in enumerate(KILL_POINTS):
        out = outs[i]
        what = f"kill {i} (frame {k} + {delay * 1e3:.1f} ms)"
        if not out.exists():
            assert main([str(case), "--restart", str(out), "--quiet"]) == 2, what
            assert main([str(case), "--out", str(out), "--quiet"]) == 0, what
            assert not list(tmp_path.glob(f".kill{i}.h5.tmp-*")), what    # the stale one gone
            assert_same_run(out, ref_out)
            seen["absent"] += 1
            continue
        h = rbsm_dyn.open_history(out)
        assert 0 < h.frames <= r.frames, what
        for p, v in h.series.items():
            assert np.all(np.isfinite(v)), (what, p)
            assert np.array_equal(v, r.series[p][:h.frames]), (what, p)
        if h.status == "completed":
            assert_same_run(out, ref_out)
            seen["completed"] += 1
            continue
        assert h.status == "running", (what, h.status)
        if checkpoint_info(out) is None:
            assert main([str(case), "--restart", str(out), "--quiet"]) == 2, what
            assert rbsm_dyn.open_history(out).frames == h.frames, what
            seen["no checkpoint"] += 1
            continue
        assert main([str(case), "--restart", str(out), "--quiet"]) == 0, what
        assert_same_run(out, ref_out)
        seen["restarted"] += 1
    assert sum(seen.values()) == 20
    assert seen["restarted"] >= 10, seen       # measured: 16-17 restarts, 3-4 before a checkpoint


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_writes_checkpoint_and_exits(ref, tmp_path, sig, code):
    """SIGTERM -> exit 143, SIGINT -> exit 130, each after finishing the
    chunk of steps and writing a checkpoint (between output steps); the
    restart from the SIGTERM one (a checkpoint between two output steps) is
    bitwise equal to the uninterrupted run."""
    case, ref_out = ref
    out = tmp_path / "stopped.h5"
    proc = _spawn(case, out)
    _wait_for(proc, lambda: _frames(out) >= 3, "three frames")
    os.kill(proc.pid, sig)
    _, err = proc.communicate(timeout=WAIT)
    assert proc.returncode == code, err
    name = signal.Signals(sig).name
    assert f"interrupted by {name}" in err and "--restart" in err
    info = checkpoint_info(out)
    assert info is not None
    h = rbsm_dyn.open_history(out)
    assert h.status.startswith(f"failed: interrupted by {name}")
    assert h.frames == info[2]
    r = rbsm_dyn.open_history(ref_out)
    assert 0 < info[0] < r.step[-1]

    if sig == signal.SIGTERM:
        assert main([str(case), "--restart", str(out), "--quiet"]) == 0
        assert_same_run(out, ref_out)


def test_restart_refused_with_exit_2(ref, tmp_path, capsys):
    """--restart with a history of another case, a static case, a missing
    file, or a file without a checkpoint: exit 2 naming the problem, and
    the history is left as it was."""
    case, ref_out = ref
    copy = tmp_path / "copy.h5"
    shutil.copy(ref_out, copy)
    before = copy.read_bytes()

    other = tmp_path / "other.yaml"
    other.write_text(textwrap.dedent(CASE).replace("divisions: [4, 4, 4]",
                                                   "divisions: [3, 4, 4]"), encoding="utf-8")
    assert main([str(other), "--restart", str(copy), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "different case" in err and "mesh.divisions" in err
    assert copy.read_bytes() == before

    static = tmp_path / "static.yaml"
    static.write_text(textwrap.dedent("""
        name: static-beam
        domain: {box: [[0, 0, 0], [0.1, 0.02, 0.02]]}
        mesh: {kind: blocks, divisions: [5, 1, 1]}
        materials: {steel: {density: 7850, young: 200.0e9, poisson: 0.0}}
        groups: {tip: {box: [[0.09, -1, -1], [1, 1, 1]]}}
        boundary: [{face: xmin, fix: all}]
        loads: [{group: tip, force: [0, 0, -10.0]}]
        solver: {mode: static, load_steps: 1, tolerance: 1.0e-4}
        """), encoding="utf-8")
    assert main([str(static), "--restart", str(copy), "--quiet"]) == 2
    assert "static" in capsys.readouterr().err

    assert main([str(case), "--restart", str(tmp_path / "missing.h5"), "--quiet"]) == 2
    assert "missing.h5" in capsys.readouterr().err

    # a run stopped before its first checkpoint: nothing to continue from
    early = tmp_path / "early.h5"
    assert main([str(case), "--out", str(early), "--quiet", "--max-steps", "0"]) == 0
    with h5py.File(early, "r+") as f:
        f["checkpoint"].attrs.modify("current", np.int64(-1))
    assert main([str(case), "--restart", str(early), "--quiet"]) == 2
    assert "no checkpoint" in capsys.readouterr().err
    assert copy.read_bytes() == before
