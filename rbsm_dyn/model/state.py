"""State: what changes each step, and new_state, the state a run starts
from (Model in core.py, its contact state in contact.py)."""
from dataclasses import dataclass

import numpy as np

from ..physics.integrate import refresh_all_rotations
from ..physics.laws import P_RATE
from .contact import new_contact_state


@dataclass
class State:
    """What changes each step.  Rows 0..N-1 are bodies, row N the ground.

    body_pos (N+1, 3) [m]; body_quat (N+1, 4); body_vel (N+1, 3) [m/s] at
    the half step; body_angmom (N+1, 3) [kg m²/s] world, half step;
    body_rot (N+1, 3, 3), body_dq (N+1, 4) derived from body_quat;
    body_wrench (N+1, 6) [N, N m]: sum of the spring forces and moments
    (about the body's centre) on each body, body_support (N+1, 3) [N]: the
    part of the force from support springs (both written by the spring
    kernels); spring_force (S, 3) [N]: force on body a, written only when a
    kernel is asked to (output steps); body_work, body_damp (N,) [J] accumulated;
    body_reaction (N, 3) [N]; step (int), dt [s].
    Inelastic springs (length S when Model.inelastic, else 0):
    spring_state (S,) int8; spring_dp (S, 3) [m] plastic gap or slip;
    spring_kappa (S,) [m] largest opening (strain law: last equivalent
    strain, physics/inelastic.py); spring_dmg (S,) damage;
    spring_wp, spring_wf (S,) [J] plastic and fracture dissipation;
    spring_rate (S,) [1/s] the smoothed rate of equivalent strain when a
    law has `rate` (else length 0; physics/laws/rupture.py smoothed_rate);
    with the Poisson correction also cell_chi (N,) χ_c at the last step
    and cell_wf (N,) [J] the energy released by its fall (physics/poisson.py).
    Plane models (length N+1 when Model.plane, else 0): body_theta [rad]
    the rotation about z from rest, body_omega [rad/s] at the half step:
    the plane passes' own (solvers/plane.py), saved by checkpoints so that
    a restart goes on bit for bit; plane_synced: they hold the plane
    state's values (else they are taken from the slab's arrays first).
    Continuum yield (length 0 unless the model has it, physics/laws/plastic.py):
    cell_moment (N+1, 6) [N m] scratch, cell_sigma (N+1, 6) [Pa] each
    cell's stress at the last spring pass, cell_dep (N+1, 6) its plastic
    strain increment for the next pass (checkpointed: cell_sigma, cell_dep).
    Viscous springs (length 0 unless Model.viscous, physics/viscous.py):
    spring_gap (S, 3) [m] the local gap of the last viscous pass,
    spring_q (S, M, 3) [N] the Maxwell branches' forces, spring_fv (S, 3)
    [N] the viscous force of the last pass, spring_wv (S,) [J] its work.
    Poisson correction scratch (length 0 unless Model.poisson_on; not
    saved by checkpoints): aux_g (n_slots, 3) [1/m], aux_p (7, N)
    (physics/poisson.py poisson_pass)."""
    body_pos: np.ndarray
    body_quat: np.ndarray
    body_vel: np.ndarray
    body_angmom: np.ndarray
    body_rot: np.ndarray
    body_dq: np.ndarray
    body_wrench: np.ndarray
    body_support: np.ndarray
    spring_force: np.ndarray
    body_work: np.ndarray
    body_damp: np.ndarray
    body_reaction: np.ndarray
    spring_state: np.ndarray = None
    spring_dp: np.ndarray = None
    spring_kappa: np.ndarray = None
    spring_dmg: np.ndarray = None
    spring_wp: np.ndarray = None
    spring_wf: np.ndarray = None
    spring_rate: np.ndarray = None
    cell_chi: np.ndarray = None
    cell_wf: np.ndarray = None
    cell_moment: np.ndarray = None
    cell_sigma: np.ndarray = None
    cell_dep: np.ndarray = None
    spring_gap: np.ndarray = None
    spring_q: np.ndarray = None
    spring_fv: np.ndarray = None
    spring_wv: np.ndarray = None
    aux_g: np.ndarray = None
    aux_p: np.ndarray = None
    body_theta: np.ndarray = None
    body_omega: np.ndarray = None
    contact: object = None        # contact.ContactState when Model.contact
    plane: object = None          # a plane model's PlaneState between chunks (solvers/plane.py)
    plane_synced: bool = False    # body_theta, body_omega hold the plane state's
    step: int = 0
    dt: float = 0.0
    t0: float = 0.0               # [s] step n is at time t0 + n dt (physics/arrays.py Stepping)
    step_base: int = 0            # the step at which dt last changed (solvers/explicit.py)

    @property
    def time(self):
        return self.t0 + self.step * self.dt


def new_state(model):
    """The State a run starts from: bodies at rest at their reference positions."""
    n, s = model.n_bodies, model.n_springs
    st = State(body_pos=model.body_pos0.copy(), body_quat=model.body_quat0.copy(),
               body_vel=np.zeros((n + 1, 3)), body_angmom=np.zeros((n + 1, 3)),
               body_rot=np.zeros((n + 1, 3, 3)), body_dq=np.zeros((n + 1, 4)),
               body_wrench=np.zeros((n + 1, 6)), body_support=np.zeros((n + 1, 3)),
               spring_force=np.zeros((s, 3)),
               body_work=np.zeros(n), body_damp=np.zeros(n), body_reaction=np.zeros((n, 3)))
    si = s if model.inelastic else 0
    st.spring_state = model.spring_state0.copy() if si else np.zeros(0, dtype=np.int8)
    st.spring_dp = np.zeros((si, 3))
    st.spring_kappa = np.zeros(si)
    st.spring_dmg = np.zeros(si)
    st.spring_wp = np.zeros(si)
    st.spring_wf = np.zeros(si)
    rated = si and bool(np.any(model.law_params[:, P_RATE] > 0))
    st.spring_rate = np.zeros(si if rated else 0)
    nc = n + 1 if model.cell_ivol.size else 0
    st.cell_moment = np.zeros((nc, 6))
    st.cell_sigma = np.zeros((nc, 6))
    st.cell_dep = np.zeros((nc, 6))
    on = model.poisson_on
    ci = n if (si and on) else 0
    st.cell_chi = np.ones(ci)      # no link is damaged at the start (cuts are no links)
    st.cell_wf = np.zeros(ci)
    sv = s if model.viscous else 0
    st.spring_gap = np.zeros((sv, 3))
    st.spring_q = np.zeros((sv, model.n_branches, 3))
    st.spring_fv = np.zeros((sv, 3))
    st.spring_wv = np.zeros(sv)
    npl = n + 1 if model.plane else 0
    st.body_theta = np.zeros(npl)
    st.body_omega = np.zeros(npl)
    st.aux_g = np.zeros((len(model.poisson.slot_cell) if on else 0, 3))
    st.aux_p = np.zeros((7, n if on else 0))
    refresh_all_rotations(n + 1, st.body_quat, model.body_quat0, st.body_rot, st.body_dq)
    if model.contact is not None:
        st.contact = new_contact_state(model)
    return st
