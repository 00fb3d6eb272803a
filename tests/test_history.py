"""Tests of rbsm_dyn.io.history (H5MD 1.1 history file)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from rbsm_dyn.io.history import HistoryWriter, open_history

ROOT = Path(__file__).resolve().parents[1]
N, S = 5, 7
POS = "particles/bodies/position"
ORI = "particles/bodies/orientation"
STATE = "springs/state"
KIN = "observables/kinetic"


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _frame(k: int) -> dict:
    """Frame k holds the value k everywhere (checkable after a kill)."""
    return {POS: np.full((N, 3), float(k)),
            ORI: np.full((N, 4), float(k)),
            STATE: np.full((S,), k % 4, dtype=np.int8),
            KIN: float(k)}


def _setup(w: HistoryWriter) -> None:
    w.write_static("particles/bodies/mass", np.arange(1.0, N + 1), "kg")
    w.write_static("particles/bodies/inertia", np.ones((N, 3, 3)), "kg m2")
    w.write_static("connectivity/springs", np.array([[i, (i + 1) % N] for i in range(S)]), "1")
    w.write_static("springs/position", np.zeros((S, 3)), "m")
    w.add_series(POS, (N, 3), np.float64, "m")
    w.add_series(ORI, (N, 4), np.float64, "1")
    w.add_series(STATE, (S,), np.int8, "1")
    w.add_series(KIN, (), np.float64, "J")


def _writer(path, **kw) -> HistoryWriter:
    params = {"case_yaml": "name: test\nsolver: {mode: dynamic}\n",
              "case": {"name": "test", "solver": {"mode": "dynamic"}},
              "versions": {"rbsm_dyn": "0.1.0", "numpy": np.__version__},
              "threads": "4"}
    return HistoryWriter(path, creator_version="0.1.0", parameters=params, **kw)


def _check_frames(h, T: int, dt: float = 1e-3) -> None:
    assert h.frames == T
    assert h.step.shape == (T,) and h.time.shape == (T,)
    np.testing.assert_array_equal(h.step, 10 * np.arange(T))
    np.testing.assert_allclose(h.time, dt * np.arange(T))
    for p, v in h.series.items():
        assert v.shape[0] == T, p
        assert h.series_time[p].shape == (T,)
    k = np.arange(T, dtype=float)
    np.testing.assert_array_equal(h.position, np.broadcast_to(k[:, None, None], (T, N, 3)))
    np.testing.assert_array_equal(h.orientation, np.broadcast_to(k[:, None, None], (T, N, 4)))
    np.testing.assert_array_equal(h.series[STATE],
                                  np.broadcast_to((np.arange(T) % 4)[:, None], (T, S)))
    np.testing.assert_array_equal(h.observables["kinetic"], k)


def test_round_trip(tmp_path):
    path = tmp_path / "run.h5"
    with _writer(path) as w:
        _setup(w)
        for k in range(6):
            assert w.append_frame(10 * k, 1e-3 * k, _frame(k)) == k + 1
        assert w.frames == 6
    with h5py.File(path, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert f["h5md/creator"].attrs["name"] == "rbsm_dyn"
        assert f["h5md/creator"].attrs["version"] == "0.1.0"
        assert f["h5md/author"].attrs["name"] == "rbsm_dyn user"
        assert f.attrs["frames"] == 6
        assert f.attrs["status"] == "completed"
        assert f[POS + "/value"].shape == (6, N, 3)
        assert f[POS + "/value"].maxshape == (None, N, 3)
        assert f[POS + "/time"].attrs["unit"] == "s"
        assert f[POS + "/step"].dtype == np.int64
        assert f[STATE + "/value"].dtype == np.int8
        assert f[KIN + "/value"].shape == (6,)
        assert f["particles/bodies/box"].attrs["dimension"] == 3
        # every dataset outside /parameters carries a unit
        missing = []
        f.visititems(lambda n, o: missing.append(n) if isinstance(o, h5py.Dataset)
                     and not n.startswith("parameters") and "unit" not in o.attrs else None)
        assert missing == []

    with open_history(path) as h:
        _check_frames(h, 6)
        assert h.status == "completed"
        assert h.h5md_version == (1, 1)
        assert h.creator == "rbsm_dyn" and h.creator_version == "0.1.0"
        np.testing.assert_array_equal(h.static["particles/bodies/mass"], np.arange(1.0, N + 1))
        assert h.static["connectivity/springs"].shape == (S, 2)
        assert h.static["particles/bodies/inertia"].shape == (N, 3, 3)
        assert h.units["particles/bodies/mass"] == "kg"
        assert h.units["particles/bodies/inertia"] == "kg m2"
        assert h.units["connectivity/springs"] == "1"
        assert h.units[POS] == "m" and h.units[KIN] == "J" and h.units[STATE] == "1"
        assert h.parameters["case_yaml"] == "name: test\nsolver: {mode: dynamic}\n"
        assert json.loads(h.parameters["case"]) == {"name": "test", "solver": {"mode": "dynamic"}}
        assert h.parameter_json("versions")["rbsm_dyn"] == "0.1.0"
        assert h.parameters["threads"] == "4"
        assert h.velocity is None and h.angular_velocity is None
        assert h.observable_time == {}
        np.testing.assert_array_equal(h.displacement, h.position - h.position[0])
        np.testing.assert_array_equal(h["particles/bodies/mass"], h.static["particles/bodies/mass"])
        assert np.array_equal(h[POS], h.position)


def test_no_frames_and_empty_dims(tmp_path):
    path = tmp_path / "empty.h5"
    with _writer(path) as w:
        w.add_series(POS, (0, 3), "f8", "m")
        w.add_series("springs/force", (0, 3), "f8", "N")
    h = open_history(path)
    assert h.frames == 0 and h.position.shape == (0, 0, 3)
    assert h.displacement.shape == (0, 0, 3) and h.time.shape == (0,)
    with _writer(path) as w:
        w.add_series("springs/force", (0, 3), "f8", "N")
        w.append_frame(0, 0.0, {"springs/force": np.zeros((0, 3))})
    assert open_history(path).series["springs/force"].shape == (1, 0, 3)


def test_errors(tmp_path):
    w = _writer(tmp_path / "e.h5")
    _setup(w)
    with pytest.raises(ValueError):
        w.write_static("h5md/x", [1], "1")
    with pytest.raises(ValueError):
        w.add_series(POS, (N, 3), "f8", "m")          # exists
    f = _frame(0)
    del f[KIN]
    with pytest.raises(KeyError):
        w.append_frame(0, 0.0, f)                     # a series is missing
    with pytest.raises(KeyError):
        w.append_frame(0, 0.0, {**_frame(0), "observables/nope": 1.0})
    with pytest.raises(ValueError):
        w.append_frame(0, 0.0, {**_frame(0), POS: np.zeros((N + 1, 3))})
    assert w.frames == 0
    w.append_frame(0, 0.0, _frame(0))
    with pytest.raises(RuntimeError):
        w.add_series("observables/late", (), "f8", "J")   # after SWMR start
    with pytest.raises(RuntimeError):
        w.write_static("springs/late", [1.0], "m")
    w.close()
    w.close()                                          # idempotent
    h = open_history(tmp_path / "e.h5")
    assert h.frames == 1 and h.status == "completed"


def test_chunks(tmp_path):
    path = tmp_path / "c.h5"
    with _writer(path) as w:
        w.add_series("a", (100_000, 3), "f8", "m")      # 2.4 MB a frame
        w.add_series("b", (1000, 3), "f8", "m")         # 24 kB a frame
        w.add_series("observables/c", (), "f8", "J")
    with h5py.File(path, "r") as f:
        assert f["a/value"].chunks == (1, 100_000, 3)
        cb = f["b/value"].chunks
        assert cb[1:] == (1000, 3) and 0.5 * 2**20 < cb[0] * 24_000 <= 2**20
        assert 1 <= f["observables/c/value"].chunks[0] <= 2**20 // 8


def test_reader_while_writer_open(tmp_path):
    path = tmp_path / "live.h5"
    w = _writer(path)
    _setup(w)
    for k in range(3):
        w.append_frame(10 * k, 1e-3 * k, _frame(k))
    # same process
    h = open_history(path)
    _check_frames(h, 3)
    assert h.status == "running"
    # another process
    code = textwrap.dedent(f"""
        import json
        from rbsm_dyn.io.history import open_history
        h = open_history({str(path)!r})
        print(json.dumps({{"frames": h.frames, "kin": h.observables["kinetic"].tolist(),
                           "pos": h.position[:, 0, 0].tolist(), "status": h.status}}))
    """)
    r = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out == {"frames": 3, "kin": [0.0, 1.0, 2.0], "pos": [0.0, 1.0, 2.0],
                   "status": "running"}
    # the writer goes on after the readers
    w.append_frame(30, 3e-3, _frame(3))
    _check_frames(open_history(path), 4)
    w.close()
    _check_frames(open_history(path), 4)


_KILL_WRITER = """
import sys, numpy as np
sys.path.insert(0, {tests!r})
from test_history import _writer, _setup, _frame
w = _writer({path!r})
_setup(w)
w.start()
k = 0
while True:
    w.append_frame(10 * k, 1e-3 * k, _frame(k))
    k += 1
"""


@pytest.mark.parametrize("min_frames", [2, 50])
def test_sigkill_leaves_readable_file(tmp_path, min_frames):
    path = tmp_path / "killed.h5"
    code = _KILL_WRITER.format(tests=str(Path(__file__).parent), path=str(path))
    p = subprocess.Popen([sys.executable, "-c", code], env=_env(),
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while True:
            assert p.poll() is None, p.stderr.read().decode()
            assert time.monotonic() < deadline, "writer made no progress"
            try:
                if open_history(path).frames >= min_frames:
                    break
            except (OSError, KeyError):
                pass                    # not created / not in SWMR mode yet
            time.sleep(0.01)
        os.kill(p.pid, signal.SIGKILL)   # while it is busy writing frames
    finally:
        if p.poll() is None:
            p.kill()
        p.wait(timeout=30)
        p.stderr.close()
    assert p.returncode == -signal.SIGKILL
    h = open_history(path)
    assert h.frames >= min_frames
    assert h.status == "running"
    _check_frames(h, h.frames)
    assert set(h.series) == {POS, ORI, STATE, KIN}
    assert h.static["particles/bodies/mass"].shape == (N,)


def test_mark_failed(tmp_path):
    path = tmp_path / "failed.h5"
    w = _writer(path)
    _setup(w)
    for k in range(4):
        w.append_frame(10 * k, 1e-3 * k, _frame(k))
    w.mark_failed("instability at step 31, t = 3.1e-3 s")
    h = open_history(path)                       # readable before close
    assert h.status == "failed: instability at step 31, t = 3.1e-3 s"
    _check_frames(h, 4)
    w.close()                                    # keeps the failed status
    h = open_history(path)
    assert h.status.startswith("failed: instability")
    _check_frames(h, 4)


def test_context_manager_marks_exception(tmp_path):
    path = tmp_path / "exc.h5"
    with pytest.raises(ZeroDivisionError):
        with _writer(path) as w:
            _setup(w)
            w.append_frame(0, 0.0, _frame(0))
            1 / 0
    h = open_history(path)
    assert h.status.startswith("failed: ZeroDivisionError")
    _check_frames(h, 1)


def test_plain_h5py_reading_with_frames(tmp_path):
    """The documented plain-h5py recipe: slice every series to `frames`."""
    path = tmp_path / "plain.h5"
    with _writer(path) as w:
        _setup(w)
        for k in range(3):
            w.append_frame(10 * k, 1e-3 * k, _frame(k))
    with h5py.File(path, "r", swmr=True) as f:
        T = int(f.attrs["frames"])
        x = f[POS + "/value"][:T]
        t = f[POS + "/time"][:T]
    assert x.shape == (3, N, 3) and t.tolist() == [0.0, 1e-3, 2e-3]


def test_buffered_frames_are_counted_when_written(tmp_path):
    """set_buffering: frames wait in memory (not counted on disk) until the
    batch is full, and are all written by mark_failed and close; the buffer
    holds copies (a caller's array changed after append_frame does not
    change the frame)."""
    path = tmp_path / "buffered.h5"
    w = _writer(path)
    _setup(w)
    w.set_buffering(frames=3, seconds=1e9)
    for k in range(2):
        fr = _frame(k)
        assert w.append_frame(10 * k, 1e-3 * k, fr) == k + 1
        fr[POS][:] = -1.0                           # the caller reuses its array
    assert w.frames == 0
    assert open_history(path).frames == 0           # nothing counted on disk yet
    w.append_frame(20, 2e-3, _frame(2))             # third frame: the batch is written
    assert w.frames == 3
    _check_frames(open_history(path), 3)
    w.append_frame(30, 3e-3, _frame(3))
    w.mark_failed("stopped")                        # pending frame written first
    _check_frames(open_history(path), 4)
    w.append_frame(40, 4e-3, _frame(4))
    w.close()
    h = open_history(path)
    _check_frames(h, 5)
    assert h.status.startswith("failed: stopped")


def test_second_writer_of_a_file_is_refused_while_the_first_is_open(tmp_path):
    """HistoryWriter holds path.lock (io/lock.py) until close(): a second
    writer of the same path (before: it truncated the file under the first)
    gets HistoryLocked naming this process; the first file stays intact."""
    from rbsm_dyn.io.lock import HistoryLocked
    path = tmp_path / "one.h5"
    w = _writer(path)
    _setup(w)
    for k in range(3):
        w.append_frame(10 * k, 1e-3 * k, _frame(k))
    with pytest.raises(HistoryLocked) as exc:
        _writer(path)
    assert f"process {os.getpid()}" in str(exc.value) and str(path) in str(exc.value)
    with pytest.raises(HistoryLocked):
        HistoryWriter.reopen(path, frames=1)
    w.close()
    assert not os.path.exists(f"{path}.lock")
    _check_frames(open_history(path), 3)


def test_staged_writer_replaces_the_file_only_at_its_first_frame(tmp_path):
    """stage=True writes .NAME.tmp-<pid>: closed (or discarded) without a
    frame it vanishes and the old file keeps its bytes; its first frame
    moves it to the name."""
    path = tmp_path / "run.h5"
    w = _writer(path)
    _setup(w)
    w.append_frame(0, 0.0, _frame(0))
    w.close()
    before = path.read_bytes()
    tmp = tmp_path / f".run.h5.tmp-{os.getpid()}"
    for end in ("close", "discard", "mark_failed"):
        w = _writer(path, stage=True)
        _setup(w)
        assert w.file_path == str(tmp) and tmp.exists()
        if end == "mark_failed":
            w.mark_failed("refused")
            end = "close"
        getattr(w, end)()
        assert not tmp.exists()
        assert path.read_bytes() == before
    w = _writer(path, stage=True)
    _setup(w)
    w.append_frame(0, 0.0, _frame(0))
    assert not tmp.exists() and w.file_path == str(path)
    w.append_frame(10, 1e-3, _frame(1))
    w.close()
    _check_frames(open_history(path), 2)


def test_truncate_drops_the_frames_after_those_kept(tmp_path):
    """HistoryWriter.truncate(k) (a static run going back on its path,
    solvers/newton.py): written and pending frames after the first k are
    dropped, the frames appended next follow them, and a reader sees k + the
    new ones with their own values."""
    path = tmp_path / "cut.h5"
    w = _writer(path)
    w.set_buffering(frames=3)
    _setup(w)
    for k in range(5):                      # 3 written, 2 pending
        w.append_frame(10 * k, 1e-3 * k, _frame(k))
    with pytest.raises(ValueError):
        w.truncate(6)
    w.truncate(2)
    assert w.frames == 2
    for k in (2, 3):
        w.append_frame(10 * k, 1e-3 * k, _frame(k))
    w.close()
    h = open_history(path)
    _check_frames(h, 4)
