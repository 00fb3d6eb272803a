"""What a run will cost, before it runs (``python -m rbsm_dyn info``).

* frames: the output schedule of each solver mode --
  dynamic: n = ceil(end_time / dt) steps, a frame every
  k = round(interval / dt) steps, at step 0 and at the last step
  (solvers/explicit.py), so 1 + floor(n / k) (+1 when k does not divide n);
  static: frame 0 and one per load step; linear: 2; modal: modes + 1.
* output size: the static part of the history is written for real, by the
  run's own Recorder, to a temporary file and measured; each series then
  grows by whole HDF5 chunks (io/history_layout.py: ``value`` in chunks of about
  1 MiB, ``step`` and ``time`` in chunks of 1024 frames), so the size after
  T frames is that file plus ceil(T / rows) chunks per dataset.  The modal
  /modes group is added (M × N × 6 float64).  This is the size of the file
  that the run leaves, within a few per cent (tests/test_info.py: a short
  run's file is within a factor 1.1 of the estimate).
* memory: the peak resident memory of the run beyond Python, NumPy and
  Numba themselves (about 150-250 MB): the bytes of every array of the
  Model (mesh included) and of the explicit State, the per-frame output
  buffers, and what the build holds besides the model at its peak
  (BUILD_PEAK_EXTRA × the model's bytes: the tessellation's and the spring
  tables' temporaries, which the allocator keeps for the run).  Measured
  (VmHWM of a run of 5 steps less that of a tiny run; git 3ce72e9 +
  this change): Voronoi box 9 259 cells 219 MiB, 19 264 cells 484 MiB;
  blocks 16 000 cells 108 MiB, 54 000 cells 428 MiB, where model + state +
  buffers alone are 117, 246, 73 and 248 MiB (0.51-0.68 of the peak; issue
  14: 6.5 GiB against 12.7 GB at 5·10⁵ bodies); with the build's share
  the measured peaks are 0.83-1.07 × the estimate (tests/test_info.py: a
  19 264-cell Voronoi run within 0.7-1.5×).  Linear and
  modal modes add the assembled sparse stiffness (36 entries per body and 72
  per touching pair, plus 9 per pair of bodies that share a neighbour when
  the Poisson correction is on; 12 bytes each, twice for the conversion to
  CSR), before
  the solver's own work space (a direct factorization takes several times
  that).
"""
from __future__ import annotations

import dataclasses
import math
import os
import tempfile

import h5py
import numpy as np

__all__ = ["Estimate", "estimate", "count_frames", "array_bytes", "format_bytes",
           "wall_seconds", "format_seconds", "ONE_DAY"]

#: B-tree and object headers per chunk written (HDF5, measured order)
CHUNK_OVERHEAD = 64

#: memory the build holds at its peak besides the model's own arrays, as a
#: share of them (module docstring: the measured run peaks less the
#: model, state and buffers are 1.05-1.16 × the model's bytes on Voronoi
#: meshes, 0.61-0.92 on blocks; tracemalloc puts the peak of the model
#: build alone at 2.2 × the model's bytes)
BUILD_PEAK_EXTRA = 1.0


#: ns per spring-point-step of the explicit step on one thread, by the
#: physics a run's passes include: `python -m rbsm_dyn bench` on the 2-core
#: machine of benchmarks/results/kernel_interface.md (200 000 bodies, after
#: the kernel interface): elastic 27.9, full physics (yield, rupture,
#: Poisson correction) 85-105 -- the lower figures, so that a long run is
#: never refused on a pessimistic estimate
NS_PER_SPRING_STEP = {"elastic": 27.0, "full": 85.0}
#: the same per body (the body pass and the output of a model with few or no
#: springs: contact of rigid bodies) and the fixed cost of a step (the chunk
#: loop, a frame's bookkeeping spread over its steps), measured on small models
NS_PER_BODY_STEP = 40.0
NS_PER_STEP = 500.0
#: a second thread's share of a thread's speed (bench, elastic and full at
#: 200 000 bodies: 1.8-1.9x on 2 threads)
THREAD_GAIN = 0.85
ONE_DAY = 86400.0


def wall_seconds(model, steps, threads=1):
    """Wall time of ``steps`` explicit steps of ``model`` on ``threads``
    threads, from bench's figures above (a lower estimate: a scene with
    contact pays its pair search on top)."""
    from .passes import Options
    opt = Options.of(model)
    kind = "full" if (opt.inelastic or opt.poisson or opt.contact) else "elastic"
    speed = 1.0 + THREAD_GAIN * (max(1, int(threads)) - 1) if opt.parallel else 1.0
    ns = (NS_PER_SPRING_STEP[kind] * model.n_springs + NS_PER_BODY_STEP * model.n_bodies) / speed
    return float(steps) * (ns + NS_PER_STEP) * 1e-9


def format_seconds(t: float) -> str:
    """A duration for a person: s, min, h or days."""
    if t < 120:
        return f"{t:.0f} s"
    if t < 7200:
        return f"{t / 60:.0f} min"
    if t < 2 * ONE_DAY:
        return f"{t / 3600:.1f} h"
    return f"{t / ONE_DAY:.3g} days"


@dataclasses.dataclass
class Estimate:
    """Figures of a case, in SI and bytes."""
    mode: str
    n_bodies: int
    n_springs: int
    n_supports: int
    dt_estimate: float            #: Model.stable_dt() [s] (contact's own bound for a
    #:                               model without springs, solvers/explicit.choose_dt)
    dt: float | None              #: step used (dynamic) [s]
    steps: int | None             #: steps to the end time (dynamic)
    out_every: int | None         #: steps between frames (dynamic)
    frames: int                   #: frames the history will hold
    static_bytes: int             #: file with no frame (measured)
    frame_bytes: float            #: value bytes per frame (payload, no chunking)
    output_bytes: int             #: estimated file size after `frames`
    model_bytes: int              #: Model + Mesh arrays
    state_bytes: int              #: State arrays
    buffer_bytes: int             #: output buffers per frame
    matrix_bytes: int = 0         #: sparse stiffness (linear, modal)
    build_bytes: int = 0          #: held by the build at its peak besides the model

    @property
    def memory_bytes(self) -> int:
        return (self.model_bytes + self.state_bytes + self.buffer_bytes + self.matrix_bytes
                + self.build_bytes)


def format_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024.0
    return f"{n:.3g} TiB"


def array_bytes(obj, _seen=None) -> int:
    """Bytes of the NumPy arrays held by a dataclass or plain object (one
    level of nested dataclasses/objects, dicts and lists; each array once)."""
    seen = set() if _seen is None else _seen
    total = 0

    def visit(v, depth):
        nonlocal total
        if isinstance(v, np.ndarray):
            base = v if v.base is None else v.base
            if id(base) not in seen:
                seen.add(id(base))
                total += int(getattr(base, "nbytes", v.nbytes))
        elif depth > 2:
            return
        elif isinstance(v, dict):
            for x in v.values():
                visit(x, depth + 1)
        elif isinstance(v, (list, tuple)):
            for x in v:
                visit(x, depth + 1)
        elif dataclasses.is_dataclass(v) and not isinstance(v, type):
            for f in dataclasses.fields(v):
                visit(getattr(v, f.name, None), depth + 1)
        elif hasattr(v, "__dict__") and not isinstance(v, type):
            for x in vars(v).values():
                visit(x, depth + 1)

    visit(obj, 0)
    return total


def _stable_dt(model):
    """The stable step estimate a run takes (solvers/explicit.choose_dt):
    the springs', or with contact and no springs, the contact's."""
    est = float(model.stable_dt())
    if model.contact is not None and model.n_springs == 0:
        from ..model.contact import contact_stable_dt
        est = min(est, float(contact_stable_dt(model)))
    return est


def count_frames(case, model):
    """(frames, steps, dt, out_every) of a run of ``case`` on ``model``;
    steps, dt, out_every are None outside the dynamic mode."""
    s = case.solver
    if s.mode == "dynamic":
        from .explicit import choose_dt
        dt, _ = choose_dt(case, model)
        n = int(np.ceil(s.end_time / dt - 1e-9))
        k = max(1, int(round(case.output.interval / dt)))
        frames = 1 + n // k + (1 if n % k else 0)
        return frames, n, dt, k
    if s.mode == "static":
        return 1 + int(s.load_steps), None, None, None
    if s.mode == "linear":
        return 2, None, None, None
    return 1 + int(s.modes), None, None, None


def _series_bytes(f: h5py.File, frames: int):
    """Bytes of every series of an open history after ``frames`` frames
    (whole chunks), and the payload per frame."""
    total = 0
    per_frame = 0.0
    groups = []
    f.visititems(lambda name, obj: groups.append(obj)
                 if isinstance(obj, h5py.Group) and isinstance(obj.get("value"), h5py.Dataset)
                 and "step" in obj else None)
    for g in groups:
        for name in ("value", "step", "time"):
            ds = g[name]
            if ds.chunks is None:
                continue
            rows = ds.chunks[0]
            chunk = ds.dtype.itemsize * math.prod(ds.chunks)
            n_chunks = math.ceil(frames / rows)
            # chunks split along the tail (frames over 1 GiB) multiply
            for d, c in zip(ds.shape[1:], ds.chunks[1:]):
                n_chunks *= math.ceil(max(d, 1) / c)
            total += n_chunks * (chunk + CHUNK_OVERHEAD)
            per_frame += ds.dtype.itemsize * math.prod(ds.shape[1:])
    return total, per_frame


def estimate(case, model, *, extra_observables=None, threads=1) -> Estimate:
    """Frames, output size and memory of a run of ``case`` (module docstring).
    Writes (and removes) a temporary history holding the static part."""
    from .output import Recorder
    frames, steps, dt, every = count_frames(case, model)
    seen: set = set()
    model_bytes = array_bytes(model, seen)
    fd, tmp = tempfile.mkstemp(suffix=".h5", prefix="rbsm_dyn_info_")
    os.close(fd)
    try:
        rec = Recorder(case, model, tmp, threads=threads,
                       extra_observables=extra_observables or {})
        buffer_bytes = array_bytes(rec, seen)      # the model's arrays counted once
        rec.close()
        static_bytes = os.path.getsize(tmp)
        with h5py.File(tmp, "r") as f:
            series_bytes, frame_bytes = _series_bytes(f, frames)
    finally:
        try:
            os.remove(tmp)
        except OSError:
            pass
    output = static_bytes + series_bytes
    if case.solver.mode == "modal":
        output += int(case.solver.modes) * model.n_bodies * 6 * 8 + 4096
    try:
        from ..model import new_state
        state_bytes = array_bytes(new_state(model))
    except Exception:          # the State is being reworked: estimate it
        state_bytes = model.n_bodies * 8 * (3 + 4 + 3 + 3 + 9 + 4 + 2 + 3) + \
            model.n_springs * 8 * 6
    # per frame: synchronized velocities and momenta, omega, the values dict
    buffer_bytes += model.n_bodies * 8 * 3 * 6
    matrix = 0
    if case.solver.mode in ("linear", "modal"):
        pairs = len({(int(a), int(b)) for a, b in np.asarray(model.spring_bodies)})
        nnz = 36 * model.n_bodies + 72 * pairs
        if model.poisson_on:
            # the Poisson correction's Bᵀ diag(λV) B couples every two
            # neighbours of a cell: 9 entries per body pair of SᵀS (upper bound)
            from ..physics.poisson import poisson_B
            S = abs(poisson_B(model.poisson, model.n_bodies)[:, ::6]).astype(bool)
            nnz += 9 * (S.T @ S).nnz
        matrix = 2 * 12 * nnz
    return Estimate(mode=case.solver.mode, n_bodies=model.n_bodies,
                    n_springs=model.n_springs, n_supports=int(model.is_support.sum()),
                    dt_estimate=_stable_dt(model), dt=dt, steps=steps,
                    out_every=every, frames=frames, static_bytes=int(static_bytes),
                    frame_bytes=float(frame_bytes), output_bytes=int(output),
                    model_bytes=int(model_bytes), state_bytes=int(state_bytes),
                    buffer_bytes=int(buffer_bytes), matrix_bytes=int(matrix),
                    build_bytes=int(BUILD_PEAK_EXTRA * model_bytes))
