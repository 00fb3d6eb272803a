"""The stable step of a deforming model (issue 30 item 6; solvers/explicit.py
StepAdapter, model/stable_step.py _face_row_sums).

A spring's force acts at the midpoint m of its two material points
(physics/springs.py deposit_b), so with a gap g its levers are l_a + g/2
and l_b − g/2.  Plastic and slip gaps lengthen them, the rotational modes
stiffen, and the exact step 2/ω_max falls: cases/impulsive_beam.yaml at
25 mm of deflection has 0.64 of its undeformed step, which is why it
diverged above 0.65 of that step.  Here: the force map's stiffness at a
deformed state is Σ BᵀCB with those levers (Kawai 1978 eq. 8b, B taken
at the midpoint), the bound of the deformed state stays below its exact
step and within the factor 2 of the undeformed bound's, and the beam runs
at the largest dt_safety with the step reduced as it deforms."""
import copy
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.case import DT_SAFETY_MAX, load_case_text
from rbsm_dyn.model import apply_initial, build_model, new_state
from rbsm_dyn.physics.integrate import FREE, refresh_all_rotations
from rbsm_dyn.physics.laws import P_SY
from rbsm_dyn.physics.rotation import axis_angle_quat, quat_matrix_np, quat_mul_np
from rbsm_dyn.solvers.explicit import advance, spring_pass, start_half_step

ROOT = Path(__file__).resolve().parent.parent
BEAM = ROOT / "cases" / "impulsive_beam.yaml"


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@pytest.fixture(scope="module")
def deformed():
    """The shipped beam coarsened to 40 × 1 × 2 blocks, thrown at 14 m/s and
    stepped at half its estimate to 2.5 ms (plastic hinges, gaps of a
    third of a cell): (model, state)."""
    text = BEAM.read_text(encoding="utf-8").replace("divisions: [80, 1, 4]",
                                                    "divisions: [40, 1, 2]")
    case = load_case_text(text)
    m = build_model(case)
    st = new_state(m)
    st.dt = 0.5 * m.stable_dt()
    apply_initial(case, m, st)
    start_half_step(m, st)
    advance(m, st, int(round(2.5e-3 / st.dt)))
    return m, st


def _free(m):
    return np.flatnonzero((m.dof_kind == FREE).reshape(-1))


def _mass(m, st, idx):
    n = m.n_bodies
    M = np.zeros((6 * n, 6 * n))
    for b in range(n):
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = m.body_mass[b] * np.eye(3)
        R = st.body_rot[b]
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = R @ np.diag(m.body_inertia[b]) @ R.T
    return M[np.ix_(idx, idx)]


def _fd_stiffness(m, st, idx, h=1e-9):
    """−∂(body wrenches)/∂(positions, world rotations) of the spring pass by
    central differences, the springs held elastic (their yield lifted) with
    the plastic gaps they have."""
    n = m.n_bodies
    saved = m.law_params.copy()
    m.law_params[:, P_SY] = 1e300
    K = np.empty((len(idx), len(idx)))
    try:
        for c, j in enumerate(idx):
            f = []
            for sign in (1.0, -1.0):
                s = copy.deepcopy(st)
                b, k = divmod(j, 6)
                if k < 3:
                    s.body_pos[b, k] += sign * h
                else:
                    q = axis_angle_quat(np.eye(3)[k - 3], sign * h)
                    s.body_quat[b] = quat_mul_np(q[None], s.body_quat[b][None])[0]
                refresh_all_rotations(n + 1, s.body_quat, m.body_quat0, s.body_rot, s.body_dq)
                spring_pass(m, s)
                f.append(s.body_wrench[:n].reshape(-1)[idx])
            K[:, c] = -(f[0] - f[1]) / (2.0 * h)
    finally:
        m.law_params[:] = saved
    return K


def _midpoint_stiffness(m, st, idx):
    """Σ Bᵀ C B with B at the midpoint levers m − x_a, m − x_b and C =
    F diag(k) Fᵀ in the pair's mid frame (Kawai 1978 eq. 8b)."""
    n = m.n_bodies
    sb = m.spring_bodies
    R = st.body_rot
    la = np.einsum("sij,sj->si", R[sb[:, 0]], m.spring_arm_a)
    lb = np.einsum("sij,sj->si", R[sb[:, 1]], m.spring_arm_b)
    g = st.body_pos[sb[:, 1]] + lb - st.body_pos[sb[:, 0]] - la
    K = np.zeros((6 * n, 6 * n))
    for s in range(m.n_springs):
        a, b = sb[s]
        qa, qb = st.body_dq[a], st.body_dq[b]
        q = qa + (qb if qa @ qb >= 0 else -qb)
        F = quat_matrix_np(quat_mul_np((q / np.linalg.norm(q))[None],
                                       m.spring_frame0[s][None]))[0]
        C = F @ np.diag(m.spring_k[s]) @ F.T
        B = np.hstack([-np.eye(3), _skew(la[s] + 0.5 * g[s]),
                       np.eye(3), -_skew(lb[s] - 0.5 * g[s])])
        Ks = B.T @ C @ B
        for i, bi in enumerate((a, b)):
            for j, bj in enumerate((a, b)):
                if bi < n and bj < n:
                    K[6 * bi:6 * bi + 6, 6 * bj:6 * bj + 6] += Ks[6 * i:6 * i + 6, 6 * j:6 * j + 6]
    return K[np.ix_(idx, idx)]


def test_deformed_stiffness_has_the_midpoint_levers_and_the_bound_holds(deformed):
    m, st = deformed
    idx = _free(m)
    M = _mass(m, st, idx)
    K_fd = _fd_stiffness(m, st, idx)
    lam_fd = float(np.max(np.linalg.eigvals(np.linalg.solve(M, K_fd)).real))
    lam_mid = float(sla.eigh(_midpoint_stiffness(m, st, idx), M, eigvals_only=True)[-1])
    exact = 2.0 / np.sqrt(lam_fd)
    # the force map's stiffness is the midpoint-lever one (central
    # differences at h = 1 nm: 1e-6 of the eigenvalue)
    assert lam_mid == pytest.approx(lam_fd, rel=1e-4)
    # the hinges' gaps lengthened the levers: the step fell (a
    # reference-state stiffness would not see it)
    ref = new_state(m)
    lam_ref = float(sla.eigh(_midpoint_stiffness(m, ref, idx), _mass(m, ref, idx),
                             eigvals_only=True)[-1])
    assert exact < 0.9 * 2.0 / np.sqrt(lam_ref)
    # the bound of the deformed state (Collatz–Wielandt: never above the
    # exact step) is as close as the undeformed bound is: within a factor 2
    # (tests/test_stability.py)
    bound = m.stable_dt(st)
    assert 0.5 * exact <= bound <= exact
    assert bound < m.stable_dt()


def _run(tmp_path, text, name, capsys):
    case = tmp_path / f"{name}.yaml"
    case.write_text(text, encoding="utf-8")
    out = tmp_path / f"{name}.h5"
    code = main([str(case), "--out", str(out), "--threads", "1"])
    printed = capsys.readouterr()
    return code, rbsm_dyn.open_history(out), printed.out + printed.err


@pytest.mark.parametrize("criterion", ["normal", "von_mises"])
def test_impulsive_beam_runs_at_the_largest_dt_safety(tmp_path, capsys, criterion):
    """The beam that diverged at dt_safety 0.9 (normal) and 0.95 (von Mises)
    before the step followed the deformation: at DT_SAFETY_MAX it completes,
    its step reduced as the hinges open, with its energy balanced to 1 %
    and its final deflection that of a run at half the step to 1 % (the
    central difference's error is O(dt²): a quarter of it remains)."""
    text = BEAM.read_text(encoding="utf-8").replace("criterion: von_mises",
                                                    f"criterion: {criterion}")
    old = "solver: {mode: dynamic, end_time: 3.0e-3}"
    assert old in text
    wf = {}
    for safety in (DT_SAFETY_MAX, 0.5 * DT_SAFETY_MAX):
        code, h, printed = _run(tmp_path, text.replace(
            old, f"solver: {{mode: dynamic, end_time: 3.0e-3, dt_safety: {safety}}}"),
            f"beam_{safety}", capsys)
        assert code == 0, printed
        eb = h.energy_balance()
        assert np.abs(eb["error"]).max() <= 0.01 * np.abs(eb["supplied"]).max()
        wf[safety] = -h.observables["mid_z"].min()
        if safety == DT_SAFETY_MAX:
            assert re.search(r"reduced \d+ times to [0-9.e+-]+ s", printed), printed
            # frames stay one output interval apart (1e-5 s) to a step
            assert np.diff(h.time).max() <= 1.0e-5 * 1.05
    assert wf[DT_SAFETY_MAX] == pytest.approx(wf[0.5 * DT_SAFETY_MAX], rel=0.01)


def test_restart_after_a_step_change_is_bitwise(tmp_path, capsys):
    """A run stopped after its step changed (--max-steps) and continued
    with --restart ends in the uninterrupted run's state, bit for bit: the
    time base (t0, step_base) is in the checkpoint."""
    text = BEAM.read_text(encoding="utf-8").replace(
        "solver: {mode: dynamic, end_time: 3.0e-3}",
        f"solver: {{mode: dynamic, end_time: 2.4e-3, dt_safety: {DT_SAFETY_MAX}}}")
    case = tmp_path / "beam.yaml"
    case.write_text(text, encoding="utf-8")
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    assert main([str(case), "--out", str(full), "--quiet", "--threads", "1"]) == 0
    h = rbsm_dyn.open_history(full)
    steps = np.asarray(h.step)
    dts = np.diff(h.time) / np.maximum(np.diff(steps), 1)
    assert dts[-1] < 0.99 * dts[0]            # the step did change before the end
    stop = int(steps[-3])
    assert main([str(case), "--out", str(part), "--quiet", "--threads", "1",
                 "--max-steps", str(stop)]) == 0
    assert main([str(case), "--out", str(part), "--quiet", "--threads", "1",
                 "--restart", str(part)]) == 0
    a, b = rbsm_dyn.open_history(full), rbsm_dyn.open_history(part)
    assert np.array_equal(a.time, b.time)
    for key in ("position", "orientation"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    for key in ("kinetic", "plastic", "external_work"):
        assert np.array_equal(a.observables[key], b.observables[key]), key
