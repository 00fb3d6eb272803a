"""`rbsm_dyn.open_history`: NumPy arrays or an xarray Dataset without
knowing the HDF5 layout, a selection of frames, and a file that a run in
another process is still writing (rbsm_dyn/io/history.py)."""
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import rbsm_dyn

from post_case import BEAM, run_beam


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    return run_beam(tmp_path_factory.mktemp("reader"))


def test_frame_selection_reads_the_same_rows_as_the_whole_file(beam):
    full = rbsm_dyn.open_history(beam)
    assert full.frames == full.frames_in_file == 22
    part = rbsm_dyn.open_history(beam, frames=slice(1, None, 5))
    np.testing.assert_array_equal(part.frame_index, [1, 6, 11, 16, 21])
    assert part.frames == 5 and part.frames_in_file == 22
    for p, v in full.series.items():
        np.testing.assert_array_equal(part.series[p], v[1::5], err_msg=p)
    np.testing.assert_array_equal(part.time, full.time[1::5])
    # displacement still measured from frame 0, which was not selected
    np.testing.assert_array_equal(part.displacement, full.displacement[1::5])
    last = rbsm_dyn.open_history(beam, frames=-1)
    np.testing.assert_array_equal(last.position[0], full.position[-1])
    assert last.observables["tip_z"][0] == full.observables["tip_z"][-1]
    listed = rbsm_dyn.open_history(beam, frames=[7, 2, 19])
    np.testing.assert_array_equal(listed.frame_index, [2, 7, 19])
    np.testing.assert_array_equal(listed.spring_state, full.spring_state[[2, 7, 19]])
    with pytest.raises(IndexError, match="22 complete frames"):
        rbsm_dyn.open_history(beam, frames=22)


def test_energy_balance_of_the_history(beam):
    """stored + dissipated = supplied to 2 % of the supplied energy (yield
    and contact on the cut, 324 steps); the initial energy is ½ m v²."""
    h = rbsm_dyn.open_history(beam)
    eb = h.energy_balance()
    ek0 = 0.5 * h.static["particles/bodies/mass"].sum() * 20.0 ** 2
    assert eb["supplied"][0] == pytest.approx(ek0, rel=1e-12)
    assert np.max(np.abs(eb["error"])) < 0.02 * ek0
    assert eb["dissipated"][-1] > 0.01 * ek0                 # the clamp yielded


def test_xarray_dataset_has_frame_body_spring_dims(beam):
    h = rbsm_dyn.open_history(beam)
    ds = rbsm_dyn.open_history(beam, xarray=True)
    assert ds.sizes["frame"] == 22 and ds.sizes["body"] == 36 and ds.sizes["spring"] == 240
    assert ds["position"].dims == ("frame", "body", "xyz")
    assert ds["orientation"].dims == ("frame", "body", "wxyz")
    assert ds["spring_state"].dims == ("frame", "spring")
    assert ds["position"].attrs["units"] == "m"
    np.testing.assert_array_equal(ds["displacement"].values, h.displacement)
    np.testing.assert_array_equal(ds["time"].values, h.time)
    np.testing.assert_array_equal(ds["tip_z"].values, h.observables["tip_z"])
    np.testing.assert_array_equal(ds["mass"].values, h.static["particles/bodies/mass"])
    np.testing.assert_array_equal(ds["spring_bodies"].values, h.static["connectivity/springs"])
    z = ds["displacement"].sel(xyz="z").isel(frame=-1).min().item()
    assert z == pytest.approx(h.displacement[-1, :, 2].min())


def test_to_xarray_without_xarray_names_the_extra(beam, monkeypatch):
    h = rbsm_dyn.open_history(beam)
    monkeypatch.setitem(sys.modules, "xarray", None)
    with pytest.raises(ImportError, match=r"rbsm_dyn\[xarray\]"):
        h.to_xarray()


def test_reading_a_file_that_another_process_is_writing(tmp_path):
    """A run in a subprocess (a frame every 2 steps, far from its end) is
    read three times while it writes: each read has consistent arrays (every
    series exactly `frames` rows) and later reads extend earlier ones row
    for row; after SIGKILL the file still reads, status "running"."""
    case = tmp_path / "long.yaml"
    case.write_text(BEAM.replace("end_time: 2.0e-4", "end_time: 1.0")
                    .replace("interval: 1.0e-5", "interval: 1.0e-6"), encoding="utf-8")
    out = tmp_path / "long.h5"
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "rbsm_dyn", str(case), "--out", str(out),
                             "--quiet"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    reads = []
    try:
        deadline = time.monotonic() + 600          # cold Numba cache on a busy machine
        while len(reads) < 3 and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()
            try:
                h = rbsm_dyn.open_history(out)
            except OSError:                        # not created / not in SWMR mode yet
                time.sleep(0.2)
                continue
            if h.frames >= 2 and (not reads or h.frames > reads[-1].frames):
                reads.append(h)
            time.sleep(0.3)
        assert len(reads) == 3, "the run did not write frames in time"
        ds = rbsm_dyn.open_history(out, xarray=True)   # xarray on the live file too
        assert ds.sizes["frame"] >= reads[-1].frames
        assert proc.poll() is None                 # still running during every read
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    for h in reads:
        assert h.status == "running"
        assert all(len(v) == h.frames for v in h.series.values())
        assert np.all(np.diff(h.time) > 0)
    for a, b in zip(reads, reads[1:]):
        assert b.frames > a.frames
        for p, v in a.series.items():
            np.testing.assert_array_equal(b.series[p][:a.frames], v, err_msg=p)
    after = rbsm_dyn.open_history(out)
    assert after.status == "running" and after.frames >= reads[-1].frames
    np.testing.assert_array_equal(after.position[:reads[-1].frames], reads[-1].position)
