"""Checkpoint and restart of dynamic runs (docs/history.md, "Checkpoint and
restart").

A checkpoint is the whole :class:`rbsm_dyn.model.State` -- every array,
``step``, ``dt`` and the time base of a run whose step has changed (``t0``,
``step_base``; 0 when read from an older file) -- plus the number of history frames written so far and
the initial energy of the divergence guard, stored in the history file under
``/checkpoint``.  HDF5 SWMR mode forbids creating datasets once frames are
appended, so the datasets are made with the rest of the file
(:func:`create_slots`, called by the Recorder) in two slots, ``slot0`` and
``slot1``, written alternately: a checkpoint fills the slot not in use,
flushes, and only then points the group attribute ``current`` at it (flushed
again).  A run killed at any moment -- even while a checkpoint is being
written -- leaves the previous checkpoint valid.

When one is written (solvers/explicit.py):

* at an output step, when ``output.checkpoint_interval`` [s of simulated
  time] has passed since the last one -- or, without that key, when
  ``DEFAULT_WALL_INTERVAL`` seconds of wall time have;
* at the end of the run (so that a completed run can be continued with a
  later ``solver.end_time``);
* on SIGINT or SIGTERM: :class:`SignalGuard` turns the signal into a flag;
  the run finishes the chunk of steps it is in, writes a checkpoint, and
  stops with :class:`Interrupted` (the command line exits 130 or 143).

Restart (``python -m rbsm_dyn CASE.yaml --restart RUN.h5``,
:func:`load_for_restart`): the case must be the one that wrote the file (same
resolved case, except ``output.file``, ``output.checkpoint_interval`` and
``solver.end_time``); the history is cut back to the checkpoint's frame
count (a frame written after the checkpoint, or half-written by a kill, is
dropped and written again) and the run goes on from the restored State.
Every array is restored bit for bit and the leapfrog resumes at the same
half step (``start_half_step`` is not applied again), and a chunk of compiled
steps gives the same result however the steps are split, so the restarted
run ends in the same state, bitwise, as a run never interrupted.
Static, linear and modal runs have no checkpoints (restart: exit 2).

Contact (model/contact.py ContactState) is in the checkpoint too, in each
slot's ``contact`` group: the candidate pairs, their slip memory, the face
that separated each and their last results, whose number changes as the
run goes (datasets that only grow, under SWMR, with ``n_pairs`` saying how
many rows hold), and each body's friction work and wrench increment, the
positions and orientations of the last broad phase and the count of broad
phases.  The broad phase and the chunks of steps depend on these alone, so
a contact run restarts bit for bit too; only the stable-step warning of
the contacts (a message) is made again after a restart.
"""
import json
import signal
import time as _time

import numpy as np

GROUP = "checkpoint"
SLOTS = ("slot0", "slot1")
#: State arrays saved (all of them: model.State)
ARRAYS = ("body_pos", "body_quat", "body_vel", "body_angmom", "body_rot", "body_dq",
          "body_wrench", "body_support", "spring_force", "body_work", "body_damp",
          "body_reaction", "spring_state", "spring_dp", "spring_kappa", "spring_dmg",
          "spring_wp", "spring_wf", "spring_rate", "cell_chi", "cell_wf", "body_theta", "body_omega",
          "cell_sigma", "cell_dep", "spring_gap", "spring_q", "spring_fv", "spring_wv")
#: State arrays a checkpoint of an older rbsm_dyn lacks (the new state's values kept)
OPTIONAL = ("spring_rate", "cell_chi", "cell_wf", "body_theta", "body_omega", "cell_sigma", "cell_dep",
            "spring_gap", "spring_q", "spring_fv", "spring_wv")
#: ContactState arrays saved: one row per candidate pair (grow as pairs come)
CONTACT_PAIR_ARRAYS = ("pairs", "slip", "sep", "out")
#: ... and one row per body
CONTACT_BODY_ARRAYS = ("body_friction", "body_dwrench", "x_build", "q_build")
#: case keys that may differ between the run and its restart
FREE_KEYS = (("output", "file"), ("output", "checkpoint_interval"), ("output", "flush_interval"),
             ("solver", "end_time"))
DEFAULT_WALL_INTERVAL = 300.0      # s of wall time between checkpoints, without the key
SIGNAL_EXIT = {signal.SIGINT: 130, signal.SIGTERM: 143}


class RestartError(ValueError):
    """A restart that cannot be made (no checkpoint, another case ...)."""


class Interrupted(Exception):
    """The run stopped on a signal after writing a checkpoint."""

    def __init__(self, signum, step, time):
        self.signum = signum
        self.step = step
        self.time = time
        self.exit_code = SIGNAL_EXIT.get(signum, 128 + int(signum))
        super().__init__(f"interrupted by {signal.Signals(signum).name} at step {step}, "
                         f"t = {time:.6g} s; checkpoint written")


# ------------------------------------------------------------------ writing

def create_slots(h5file, state):
    """Make /checkpoint with two empty slots shaped like ``state`` (before
    SWMR starts)."""
    g = h5file.create_group(GROUP)
    g.attrs["current"] = np.int64(-1)
    g.attrs["format"] = np.int64(1)
    for name in SLOTS:
        s = g.create_group(name)
        for a in ARRAYS:
            arr = getattr(state, a)
            # written now (zeros), so that the file has its full size from the
            # start and a checkpoint only overwrites
            s.create_dataset(a, data=np.zeros(arr.shape, dtype=arr.dtype))
        for a, dt in (("step", np.int64), ("dt", np.float64), ("frames", np.int64),
                      ("e0", np.float64), ("time", np.float64), ("t0", np.float64),
                      ("step_base", np.int64)):
            s.create_dataset(a, data=dt(0))
        cs = getattr(state, "contact", None)
        if cs is not None:
            c = s.create_group("contact")
            for a in CONTACT_PAIR_ARRAYS:
                arr = getattr(cs, a)
                tail = arr.shape[1:]
                c.create_dataset(a, shape=(0,) + tail, maxshape=(None,) + tail,
                                 dtype=arr.dtype, chunks=(1024,) + tail)
            for a in CONTACT_BODY_ARRAYS:
                arr = getattr(cs, a)
                c.create_dataset(a, data=np.zeros(arr.shape, dtype=arr.dtype))
            c.create_dataset("n_pairs", data=np.int64(0))
            c.create_dataset("builds", data=np.int64(0))


class Checkpointer:
    """Writes checkpoints into the history of a Recorder (None: no slots)."""

    def __init__(self, recorder, case):
        self.writer = recorder.writer
        f = self.writer.h5file
        self.group = f[GROUP] if GROUP in f else None
        self.interval = getattr(case.output, "checkpoint_interval", None)
        self.last_time = None
        self.last_wall = _time.monotonic()
        self.count = 0

    @property
    def enabled(self):
        return self.group is not None

    def due(self, state):
        """At an output step: has the interval passed since the last one?"""
        if not self.enabled:
            return False
        if self.interval is not None:
            last = 0.0 if self.last_time is None else self.last_time
            return state.time >= last + self.interval * (1.0 - 1e-9)
        return _time.monotonic() - self.last_wall >= DEFAULT_WALL_INTERVAL

    def mark(self, state):
        """The run starts (or resumes) at this state: intervals count from here."""
        self.last_time = state.time
        self.last_wall = _time.monotonic()

    def write(self, state, e0):
        if not self.enabled:
            return
        self.writer.flush_frames()       # the slot counts frames on disk
        g = self.group
        cur = int(g.attrs["current"])
        slot = SLOTS[0] if cur != 0 else SLOTS[1]
        s = g[slot]
        for a in ARRAYS:
            arr = getattr(state, a)
            if arr.size:
                s[a][...] = arr
        s["step"][()] = np.int64(state.step)
        s["dt"][()] = np.float64(state.dt)
        s["time"][()] = np.float64(state.time)
        s["t0"][()] = np.float64(state.t0)
        s["step_base"][()] = np.int64(state.step_base)
        s["frames"][()] = np.int64(self.writer.frames)
        s["e0"][()] = np.float64(e0)
        if "contact" in s:
            _write_contact(s["contact"], state.contact)
        f = self.writer.h5file
        f.flush()                                    # the slot is on disk ...
        g.attrs.modify("current", np.int64(SLOTS.index(slot)))
        f.flush()                                    # ... and only then current
        self.count += 1
        self.mark(state)


def _write_contact(c, cs):
    """The ContactState into a slot's contact group (the pair datasets grow
    to the pairs' count when short: SWMR lets a dataset grow, not shrink)."""
    n_pairs = len(cs.pairs)
    for a in CONTACT_PAIR_ARRAYS:
        ds = c[a]
        if ds.shape[0] < n_pairs:
            ds.resize(n_pairs, axis=0)
        if n_pairs:
            ds[:n_pairs] = getattr(cs, a)
    for a in CONTACT_BODY_ARRAYS:
        arr = getattr(cs, a)
        if arr.size:
            # (a file of an older rbsm_dyn has no ground row in x_build:
            # its ground is at rest, and the restore puts the row back)
            c[a][...] = arr[:c[a].shape[0]]
    c["n_pairs"][()] = np.int64(n_pairs)
    c["builds"][()] = np.int64(cs.builds)


def _read_contact(c):
    """The saved ContactState arrays of a slot's contact group (dict)."""
    n_pairs = int(c["n_pairs"][()])
    out = {a: c[a][:n_pairs] for a in CONTACT_PAIR_ARRAYS}
    out.update({a: c[a][()] for a in CONTACT_BODY_ARRAYS})
    out["builds"] = int(c["builds"][()])
    return out


def _restore_contact(state, model, saved, path):
    """Put the saved contact arrays into the fresh ContactState of ``state``."""
    from ..physics.collide import body_pairs
    cs = state.contact
    if saved is None:
        raise RestartError(f"--restart {path}: the checkpoint holds no contact state (written "
                           "by an older rbsm_dyn, which could not restart contact runs); run "
                           "the case again")
    for a in CONTACT_PAIR_ARRAYS + CONTACT_BODY_ARRAYS:
        arr = getattr(cs, a)
        got = saved[a]
        if a == "x_build" and got.shape[0] == arr.shape[0] - 1:
            # an older checkpoint: no ground row (the ground was at rest)
            got = np.vstack([got, state.body_pos[-1:]])
        if got.shape[1:] != arr.shape[1:] or got.dtype != arr.dtype or \
                (a in CONTACT_BODY_ARRAYS and got.shape != arr.shape):
            raise RestartError(f"--restart {path}: checkpoint contact array {a} has shape "
                               f"{got.shape} {got.dtype}, the model needs {arr.shape} "
                               f"{arr.dtype} (a different mesh or rbsm_dyn version)")
        setattr(cs, a, np.ascontiguousarray(got))
    cs.builds = saved["builds"]
    cs.ptr, cs.entry = body_pairs(cs.pairs, model.n_bodies)


# ------------------------------------------------------------------ signals

class SignalGuard:
    """Within the block, SIGINT and SIGTERM set ``signum`` instead of
    stopping the process (a second one raises KeyboardInterrupt at once);
    the previous handlers come back on exit.  Outside the main thread it
    does nothing."""

    def __init__(self):
        self.signum = None
        self._old = {}

    def _handler(self, signum, frame):
        if self.signum is not None:
            raise KeyboardInterrupt
        self.signum = signum

    def __enter__(self):
        for sig in SIGNAL_EXIT:
            try:
                self._old[sig] = signal.signal(sig, self._handler)
            except (ValueError, OSError):       # not the main thread
                pass
        return self

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()


# ------------------------------------------------------------------ reading

def checkpoint_info(path):
    """(step, time, frames) of the last valid checkpoint in a history file,
    or None (no checkpoint yet).  Works on a file still being written."""
    from ..io.history import _open_h5
    with _open_h5(str(path)) as f:
        if GROUP not in f:
            return None
        g = f[GROUP]
        cur = int(g.attrs["current"])
        if cur < 0:
            return None
        s = g[SLOTS[cur]]
        return int(s["step"][()]), float(s["time"][()]), int(s["frames"][()])


def read_checkpoint(path, *, writer_alive=None):
    """The last valid checkpoint: dict of the State arrays and ``step``,
    ``dt``, ``time``, ``frames``, ``e0``; and the resolved case (JSON
    text) of the run.  Raises RestartError (naming the file: missing, not
    HDF5, truncated or damaged -- at once, io/history_reader.py _open_h5).
    ``writer_alive=False``: the caller holds the file's lock (a restart),
    so no writer can be waited for."""
    from ..io.history import _open_h5
    try:
        f = _open_h5(str(path), writer_alive=writer_alive)
    except (OSError, ValueError) as exc:
        raise RestartError(f"--restart {exc}") from None
    try:
        with f:
            return _read_checkpoint(f, path)
    except RestartError:
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        raise RestartError(f"--restart {path}: cannot read the checkpoint, the file is "
                           f"damaged ({exc})") from None


def _read_checkpoint(f, path):
    """The checkpoint of the open history ``f`` (read_checkpoint)."""
    if GROUP not in f:
        raise RestartError(f"{path}: no /checkpoint group (not a dynamic run's history, "
                           "or written by an older rbsm_dyn)")
    g = f[GROUP]
    cur = int(g.attrs["current"])
    if cur < 0:
        raise RestartError(f"{path}: holds no checkpoint yet (the run stopped before "
                           "writing one); run the case again from the start")
    s = g[SLOTS[cur]]
    out = {a: s[a][()] for a in ARRAYS if a in s or a not in OPTIONAL}
    for a in ("step", "dt", "time", "frames", "e0"):
        out[a] = s[a][()].item()
    for a in ("t0", "step_base"):
        # a run whose step changed (solvers/explicit.py); 0 in older files
        out[a] = s[a][()].item() if a in s else 0
    out["contact"] = _read_contact(s["contact"]) if "contact" in s else None
    case = f["parameters/case"].asstr()[()] if "parameters/case" in f else None
    frames_in_file = int(f.attrs.get("frames", 0))
    if out["frames"] > frames_in_file:
        raise RestartError(f"{path}: the checkpoint counts {out['frames']} frames but the "
                           f"file has {frames_in_file}")
    return out, case


def _first_difference(a, b, path=()):
    """Key path of the first difference between two JSON values, or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if k not in a or k not in b:
                return path + (k,)
            d = _first_difference(a[k], b[k], path + (k,))
            if d is not None:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b) or not any(isinstance(x, (dict, list)) for x in a + b):
            return None if a == b else path
        for j, (x, y) in enumerate(zip(a, b)):
            d = _first_difference(x, y, path + (j,))
            if d is not None:
                return d
        return None if a == b else path
    return None if a == b else path


def _drop_free(d):
    d = json.loads(json.dumps(d))
    for sec, key in FREE_KEYS:
        if isinstance(d.get(sec), dict):
            d[sec].pop(key, None)
    return d


def load_for_restart(case, model, path, *, writer_alive=None):
    """Check that ``path`` can continue ``case`` and return its checkpoint
    as a restored State.  Raises RestartError naming the problem.
    ``writer_alive=False``: the caller holds the history's lock
    (read_checkpoint)."""
    from ..model import new_state
    if case.solver.mode != "dynamic":
        raise RestartError(f"--restart: solver.mode {case.solver.mode} has no checkpoints "
                           "(only dynamic runs can be restarted; run the case again)")
    data, case_json = read_checkpoint(path, writer_alive=writer_alive)
    if case_json is not None:
        then = _drop_free(json.loads(case_json))
        now = _drop_free(json.loads(json.dumps(case.resolved())))
        diff = _first_difference(then, now)
        if diff is not None:
            key = ".".join(str(k) for k in diff) or "(top level)"

            def show(d):
                for k in diff:
                    try:
                        d = d[k]
                    except (KeyError, IndexError, TypeError):
                        return "absent"
                return json.dumps(d)
            raise RestartError(f"--restart {path}: the file was written by a different case: "
                               f"{key} is {show(then)} there and {show(now)} here")
    state = new_state(model)
    for a in ARRAYS:
        arr = getattr(state, a)
        if a not in data:
            continue                       # OPTIONAL, from an older checkpoint
        saved = data[a]
        if saved.shape != arr.shape or saved.dtype != arr.dtype:
            raise RestartError(f"--restart {path}: checkpoint array {a} has shape "
                               f"{saved.shape} {saved.dtype}, the model needs {arr.shape} "
                               f"{arr.dtype} (a different mesh or rbsm_dyn version)")
        setattr(state, a, np.ascontiguousarray(saved))
    if model.contact is not None:
        _restore_contact(state, model, data["contact"], path)
    # a plane model's θ, ω as they were (solvers/plane.py), not from the slab's
    state.plane_synced = len(state.body_theta) > 0 and "body_theta" in data
    state.step = int(data["step"])
    state.dt = float(data["dt"])
    state.t0 = float(data.get("t0", 0.0))
    state.step_base = int(data.get("step_base", 0))
    return state, data
