"""Modal mode: natural frequencies and mode shapes of the linearised model,
K φ = ω² M φ (Kawai 1978, eq. 8b for K; lumped M: body mass and world
inertia R diag(I) Rᵀ about the centroid).

Constrained DOFs (fixed components, prescribed displacements or
velocities) are removed: the modes are those of the structure held there.
Supports on faces are springs in K.  Loads and initial conditions play no
part.

* The lowest `solver.modes` frequencies: shift-invert Lanczos
  (scipy eigsh, mode normal; (K − σM) factorised by SuperLU as in the
  linear mode) about σ = −1e-10 λ_max, so that (K − σM) is
  positive definite even for a model with free rigid-body motions.  The r
  rigid-body modes left free by the supports (r = 6 for a free model; counted
  from the six rigid modes that vanish on the constrained DOFs and lie in
  the null space of K) are computed, reported in the table as rigid, and
  not counted among the `modes` elastic ones.
* The highest frequency ω_max: Lanczos for the largest eigenvalue of the
  pencil (K, M) (eigsh which='LA', M⁻¹ by the block-diagonal LU of M).  It
  gives the exact stable step of the central-difference scheme, 2/ω_max
  (e.g. Belytschko, Liu & Moran, Nonlinear FE, §6.3), to compare with the
  Gershgorin estimate Model.stable_dt() that the explicit solver uses.

History (docs/history.md): frame 0 the undeformed model; frame k = 1..M the
k-th elastic mode drawn at `display amplitude` (largest translation 1 % of
the domain's largest side), `step` = `time` = k, observable `frequency`
[Hz] (0 in frame 0).  The exact data is written to the group /modes:
frequency (M,) Hz, omega (M,) rad s-1, shape (M, N, 6) (ux, uy, uz, θx, θy,
θz per body, world axes; scaled so that the largest translation is 1, so
the rotations are in rad per metre of it), modal_mass (M,) kg (φᵀMφ of the
scaled shape), omega_max () rad s-1, stable_dt () s = 2/ω_max,
stable_dt_estimate () s (Model.stable_dt()), rigid_modes () the number r.
/modes is added when the run has written its frames (HDF5 in SWMR mode
cannot create datasets while frames are appended).
"""
import time as _time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..model import new_state
from ..physics.integrate import FREE
from ..stiffness import mass_matrix, rigid_modes, stiffness_matrix
from .linear import displaced_state, factorize

__all__ = ["ModalResult", "omega_max", "natural_modes", "run", "write_modes_group",
           "DISPLAY_FRACTION"]

DISPLAY_FRACTION = 0.01     # drawn mode: largest translation / largest domain side
SHIFT = 1e-10               # σ = −SHIFT·λ_max


class ModalResult:
    """omega (M,) [rad/s] elastic modes, ascending; frequency (M,) [Hz];
    shape (M, N, 6) scaled to unit largest translation; modal_mass (M,) [kg];
    rigid_omega (r,) [rad/s] (≈ 0); omega_max [rad/s]; times [s]."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


def _reduced(model, K=None, M=None):
    K = stiffness_matrix(model) if K is None else K
    M = mass_matrix(model) if M is None else M
    free = model.dof_kind.reshape(-1) == FREE
    Kff = sp.csr_matrix(K)[free][:, free].tocsc()
    Mff = sp.csr_matrix(M)[free][:, free].tocsc()
    return K, M, free, Kff, Mff


def _minv(Mff):
    lu = spla.splu(Mff)              # block diagonal: no fill
    return spla.LinearOperator(Mff.shape, matvec=lu.solve, dtype=float)


def omega_max(model, *, K=None, M=None, tol=1e-8):
    """Highest natural angular frequency [rad/s] of the model with its
    constrained DOFs removed (Lanczos on the largest eigenvalue of (K, M))."""
    _, _, _, Kff, Mff = _reduced(model, K, M)
    return _omega_max(Kff, Mff, tol)


def _omega_max(Kff, Mff, tol=1e-8):
    n = Kff.shape[0]
    if n == 0 or Kff.nnz == 0 or not np.any(Kff.data):
        # no stiffness (free rigid bodies, or cells held by contact only):
        # every frequency is 0 (ARPACK stops on a zero operator)
        return 0.0
    if n <= 12:
        lam = np.linalg.eigvals(np.linalg.solve(Mff.toarray(), Kff.toarray())).real.max()
        return float(np.sqrt(max(lam, 0.0)))
    v0 = np.random.default_rng(0).standard_normal(n)
    lam = spla.eigsh(Kff, k=1, M=Mff, Minv=_minv(Mff), which="LA", tol=tol,
                     v0=v0, return_eigenvectors=False)
    return float(np.sqrt(max(lam[0], 0.0)))


def count_rigid_modes(model, K, free):
    """Number of rigid-body motions left free by supports and constrained
    DOFs: rigid modes zero on every constrained DOF and in the null space of K."""
    phi = rigid_modes(model)
    pres = ~free
    _, sv, vt = np.linalg.svd(phi[pres], full_matrices=True)
    rank = int(np.sum(sv > 1e-10 * max(1.0, sv.max(initial=0.0))))
    combos = vt[rank:].T
    if combos.shape[1] == 0:
        return 0
    modes = phi @ combos
    scale = abs(K).sum(axis=1).max()
    # the rigid motions that K does not resist
    _, s2, _ = np.linalg.svd(K @ modes / np.linalg.norm(modes, axis=0), full_matrices=False)
    return int(np.sum(s2 <= 1e-9 * scale))


def natural_modes(model, n_modes=6, *, K=None, M=None, tol=0.0):
    """The lowest `n_modes` elastic natural modes of the model (and ω_max).
    Returns a ModalResult.  Raises ValueError when the model has fewer free
    DOFs than asked for."""
    t0 = _time.perf_counter()
    K, M, free, Kff, Mff = _reduced(model, K, M)
    t_asm = _time.perf_counter() - t0
    nf = Kff.shape[0]
    r = count_rigid_modes(model, sp.csr_matrix(K), free)
    want = n_modes + r
    if want >= nf:
        raise ValueError(f"asked for {n_modes} modes, but the model has only {nf} free "
                         f"DOFs ({r} of them rigid-body motions)")
    t1 = _time.perf_counter()
    wmax = _omega_max(Kff, Mff)
    t_max = _time.perf_counter() - t1
    t2 = _time.perf_counter()
    sigma = -SHIFT * wmax ** 2
    v0 = np.random.default_rng(1).standard_normal(nf)
    lu = factorize(Kff - sigma * Mff)
    opinv = spla.LinearOperator(Kff.shape, matvec=lu.solve, dtype=float)
    lam, vec = spla.eigsh(Kff, k=want, M=Mff, sigma=sigma, which="LM", tol=tol, v0=v0,
                          OPinv=opinv)
    t_eig = _time.perf_counter() - t2
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    omega_all = np.sqrt(np.clip(lam, 0.0, None))
    n = model.n_bodies
    full = np.zeros((6 * n, want))
    full[free] = vec
    shapes = full.T.reshape(want, n, 6)[r:]
    scale = np.abs(shapes[:, :, :3]).max(axis=(1, 2))
    scale[scale == 0] = 1.0
    shapes = shapes / scale[:, None, None]
    # φ is M-orthonormal from eigsh: the scaled shape has modal mass 1/scale²
    modal_mass = 1.0 / scale ** 2
    omega = omega_all[r:]
    return ModalResult(omega=omega, frequency=omega / (2 * np.pi), shape=shapes,
                       modal_mass=modal_mass, rigid_omega=omega_all[:r], omega_max=wmax,
                       n_free=nf, assembly_time=t_asm, omega_max_time=t_max, eigsh_time=t_eig,
                       K=K, M=M)


def table(res, dt_estimate):
    """The printed table (str)."""
    lines = [f"{'mode':>5} {'frequency [Hz]':>16} {'ω [rad/s]':>14} {'modal mass [kg]':>16}"]
    for k, w in enumerate(res.rigid_omega):
        lines.append(f"{'r' + str(k + 1):>5} {w / (2 * np.pi):16.6g} {w:14.6g} {'(rigid body)':>16}")
    for k, (f, w, mm) in enumerate(zip(res.frequency, res.omega, res.modal_mass)):
        lines.append(f"{k + 1:>5} {f:16.6g} {w:14.6g} {mm:16.6g}")
    dt_exact = 2.0 / res.omega_max if res.omega_max > 0 else np.inf
    lines.append(f"highest: ω_max = {res.omega_max:.6g} rad/s "
                 f"({res.omega_max / (2 * np.pi):.6g} Hz); stable step 2/ω_max = {dt_exact:.4g} s, "
                 f"estimate Model.stable_dt() = {dt_estimate:.4g} s "
                 f"(ratio {dt_estimate / dt_exact:.3f})")
    return "\n".join(lines)


def run(case, model, recorder, *, max_steps=None, progress=None, out=None):
    """Compute the modes, write the frames (see the module docstring) and
    print the table.  `max_steps` is ignored (no time steps)."""
    n = model.n_bodies
    try:
        res = natural_modes(model, case.solver.modes)
    except ValueError as exc:
        raise case.error(("solver", "modes"), str(exc)) from None
    from .explicit import spring_pass
    zero = np.zeros((n, 3))
    box = np.asarray(model.mesh.box if model.mesh is not None
                     else [model.body_pos0[:-1].min(axis=0), model.body_pos0[:-1].max(axis=0)])
    amp = DISPLAY_FRACTION * float(np.max(box[1] - box[0]))
    state = new_state(model)
    spring_pass(model, state)
    obs = {"kinetic": 0.0, "strain": 0.0, "external_work": 0.0, "damping": 0.0,
           "n_broken": 0.0, "frequency": 0.0}
    recorder.append(state, 0, 0.0, zero, zero, obs, np.zeros(n))
    for k in range(len(res.omega)):
        U = amp * res.shape[k]
        state = displaced_state(model, U)
        spring_pass(model, state)
        Uf = U.reshape(-1)
        obs = {"kinetic": 0.0, "strain": 0.5 * float(Uf @ (res.K @ Uf)), "external_work": 0.0,
               "damping": 0.0, "n_broken": 0.0, "frequency": float(res.frequency[k])}
        recorder.append(state, k + 1, float(k + 1), zero, zero, obs, np.zeros(n))
    res.dt_estimate = model.stable_dt()
    res.display_amplitude = amp
    print(table(res, res.dt_estimate))
    return dict(result=res, modes=len(res.omega), omega_max=res.omega_max,
                dt_estimate=res.dt_estimate)


def write_modes_group(path, res):
    """Add the /modes group of a modal run to the (closed) history file."""
    import h5py
    with h5py.File(path, "a") as f:
        g = f.require_group("modes")
        dt_exact = 2.0 / res.omega_max if res.omega_max > 0 else np.inf
        for name, val, unit in (
                ("frequency", res.frequency, "Hz"), ("omega", res.omega, "rad s-1"),
                ("shape", res.shape, "1"), ("modal_mass", res.modal_mass, "kg"),
                ("rigid_omega", res.rigid_omega, "rad s-1"),
                ("rigid_modes", np.int64(len(res.rigid_omega)), "1"),
                ("omega_max", np.float64(res.omega_max), "rad s-1"),
                ("stable_dt", np.float64(dt_exact), "s"),
                ("stable_dt_estimate", np.float64(res.dt_estimate), "s"),
                ("display_amplitude", np.float64(res.display_amplitude), "m")):
            if name in g:
                del g[name]
            ds = g.create_dataset(name, data=val)
            ds.attrs["unit"] = unit
        g["shape"].attrs["columns"] = ("ux uy uz [1: largest translation of the mode = 1], "
                                       "θx θy θz [rad per unit of that translation, m-1]")
