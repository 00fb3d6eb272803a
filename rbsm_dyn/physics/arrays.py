"""The kernels' containers: Model, State and Options of the compiled step.

A kernel takes a few NamedTuples of arrays (Numba types, passes and caches
them like tuples), not dozens of positional arrays: a new feature adds a
field or a container, not a parameter to every signature (DESIGN.md §11,
STYLE.md 10).  Grouped by entity, named as the Python-side Model and State
attributes they hold (model.py), with shapes and units:

Model (static over a run)
  Bodies         body_mass (N,) [kg]; body_inertia (N, 3) principal
                 moments [kg m²]; body_pos0 (N+1, 3) [m]; body_quat0 (N+1, 4)
                 (row N: the ground)
  Springs        spring_bodies (S, 2) int32 (b = N: support); spring_arm_a,
                 spring_arm_b (S, 3) [m] principal-frame arms; spring_slot
                 (S,) int32 face row; spring_area (S,) [m²]; face_frame0
                 (F, 4); face_k (F, 3) [N/m³]; face_h (F,) [m]; face_law (F,)
                 int32; law_params (L, N_PARAMS) [Pa, 1, J/m²]; group_ptr
                 (G+1,), phase_ptr (P+1,) the thread-safe schedule
                 (partition.py); cell_ivol (N+1,) [1/m³] 1/V (0: the
                 ground), cell_plane (N+1,) int8 a plane-strain slab's
                 axis or −1, cell_lever (N+1, 3, 3) [m] the levers of held
                 translations' reactions, cell_k, cell_2g (N+1,) [Pa] the
                 shear strength and 2G (length 0 without continuum yield)
  Loads          body_fext, body_mext (N, 3) [N, N m] dead loads;
                 body_ffol, body_mfol (N, 3) or (0, 3) follower loads
                 (principal frame); body_load_hist (N,) int32; gravity (3,)
                 [m/s²]; dof_kind (N, 6) int8, dof_value (N, 6) [m/s or m],
                 dof_hist (N, 6) int32; amplitude tables hist_ptr, hist_t
                 [s], hist_a; the ground's motion (the ground row N of
                 the BodyState moves with it): ground_hist (1,) int32 its
                 velocity's table (−1: at rest), ground_dir (3,) [1]
State (changes every step)
  BodyState      body_pos (N+1, 3) [m]; body_quat (N+1, 4); body_vel (N+1, 3)
                 [m/s] and body_angmom (N+1, 3) [kg m²/s] at the half step;
                 body_rot (N+1, 3, 3), body_dq (N+1, 4) from body_quat;
                 body_wrench (N+1, 6) [N, N m], body_support (N+1, 3) [N]
                 (written by the spring pass); body_work, body_damp (N,) [J];
                 body_reaction (N, 3) [N]; spring_force (S, 3) [N] the force
                 on body a of each spring (written when a pass is asked to
                 `store`: output steps)
  SpringHistory  spring_state (S,) int8; spring_dp (S, 3) [m]; spring_kappa
                 (S,); spring_dmg (S,); spring_wp, spring_wf (S,) [J];
                 spring_rate (S,) [1/s] (length 0 without a `rate` law)
                 (physics/inelastic.py); cell_chi (N,) the auxiliary
                 stress's factor χ_c at the last step and cell_wf (N,) [J]
                 the energy its fall released (physics/poisson.py; length
                 0 without the Poisson correction);
                 continuum yield (laws/plastic.py;
                 length 0 without it): cell_moment (N+1, 6) [N m]
                 gathered Σ sym(l ⊗ f), cell_sigma (N+1, 6) [Pa] the cell
                 stress of the last pass (xx yy zz yz xz xy), cell_dep
                 (N+1, 6) its plastic strain increment for the next pass
Features (None when a scene does not use them: the pass is not compiled)
  PoissonSlots   the auxiliary stress (physics/poisson.py): cell_slot_ptr
                 (N+1,) int32 each cell's links (slots); slot_cell,
                 slot_rev (n_slots,) int32 the neighbour and the reverse
                 slot; slot_g (n_slots, 3) [1/m] gains (principal frame);
                 cell_c0 (N,); slot_s0, slot_s1 (n_slots,) int32 the face's
                 spring points; cell_lv (N,) [J] λ V; scratch aux_g
                 (n_slots, 3) [1/m], aux_p (7, N)
  ContactArrays  contact between any cells (physics/collide.py).  State:
                 pairs (P, 2) int32, slip (P, 3) [m], sep (P,) int32, out
                 (P, N_OUT), ptr (N+1,), entry (2P,) each body's pairs,
                 body_friction (N,) [J], body_dwrench (N, 6).  Geometry of
                 the cells in their principal frames (model/contact.py):
                 cell_face_ptr (N+1,), loop_ptr (F+1,), loop_xyz (L, 3)
                 [m], face_plane (F, 4), cell_loop_ptr (N+1,), vert_ptr
                 (N+1,), vert_xyz (V, 3) [m], radius, body_size (N,) [m],
                 body_e, body_g (N,) [Pa], body_rigid (N,) uint8, ground
                 (4,) the plane n·x ≤ d; mu [1], kfac [1], zeta [1];
                 scratch (threads, rows, 3); overwrite (no springs)
  Stepping       dt [s], damping_alpha [1/s], damping_local [1], t0 [s]
  ViscousSprings viscous springs (physics/viscous.py): per law row the
                 dashpot time law_dashpot (L,) [s] and the Maxwell
                 branches' shares law_g and step factors law_a, law_b
                 (L, M), kelvin_a, kelvin_b (L,) or (0,) (static in
                 time); per spring point spring_gap (S, 3) [m], spring_q
                 (S, M, 3) [N], spring_fv (S, 3) [N], spring_wv (S,) [J];
                 spring_state (the history's, or length 0); inv_dt [1/s]
  Relaxation     dynamic relaxation's fictitious masses and iteration arrays

Options: which passes a run compiles and calls, chosen once per run in
Python (solvers/passes.py).  A switch that is off passes None for its
container: Numba prunes `if x is None` branches before typing, so the pass
behind it is neither typed nor compiled (a bool flag or numba.literally
still compiles both branches; a function passed as an argument is not
cached across processes: measured, numba 0.68).  The pruning works one
way only: when x is not None, `if x is None:` is kept and its arm is
compiled too; where both arms call a pass, it is chosen by x's type with
numba.extending.overload (passes.spring_pass, inelastic._inelastic_threads).

Rules that keep the containers as fast and as correct as separate arrays
(measured, numba 0.68, issue 26): a parallel kernel copies the fields it
uses into locals before its first prange; inside a prange body no field
is read (a field written inside a prange can lose its writes), and a
container goes only whole into a compiled call (numba issue 7135: the
callee's writes are kept), in a function with no other loop (a container
passed to a call inside a prange hid the writes from the loop fuser); no tuple of NamedTuples (crashes, or compiles for minutes);
classes at module level only (tests/test_kernel_interface.py checks); no
work after a prange loop in the same function (the ground's drift written
there was lost: integrate.move_ground is a call after the loop's
function instead, measured numba 0.68); and
a constant passed from compiled code to a kernel is typed Literal[bool]
and compiles a variant of the callee of its own beside the bool of a
Python caller: flag() makes it a run-time bool where one variant is
wanted (the time loops keep store constant on purpose, for the
speed of the folded branch: docs/modules.md).
"""
from typing import NamedTuple

import numba as nb
import numpy as np


class Bodies(NamedTuple):
    """Static arrays of the bodies (see module docstring)."""
    body_mass: np.ndarray
    body_inertia: np.ndarray
    body_pos0: np.ndarray
    body_quat0: np.ndarray


class Springs(NamedTuple):
    """Spring points, their face table, laws and schedule."""
    spring_bodies: np.ndarray
    spring_arm_a: np.ndarray
    spring_arm_b: np.ndarray
    spring_slot: np.ndarray
    spring_area: np.ndarray
    face_frame0: np.ndarray
    face_k: np.ndarray
    face_h: np.ndarray
    face_law: np.ndarray
    law_params: np.ndarray
    group_ptr: np.ndarray
    phase_ptr: np.ndarray
    cell_ivol: np.ndarray
    cell_plane: np.ndarray
    cell_lever: np.ndarray
    cell_k: np.ndarray
    cell_2g: np.ndarray


class Loads(NamedTuple):
    """Loads, constraints and their amplitude tables."""
    body_fext: np.ndarray
    body_mext: np.ndarray
    body_ffol: np.ndarray
    body_mfol: np.ndarray
    body_load_hist: np.ndarray
    gravity: np.ndarray
    dof_kind: np.ndarray
    dof_value: np.ndarray
    dof_hist: np.ndarray
    hist_ptr: np.ndarray
    hist_t: np.ndarray
    hist_a: np.ndarray
    ground_hist: np.ndarray
    ground_dir: np.ndarray


class BodyState(NamedTuple):
    """What changes per body (see module docstring)."""
    body_pos: np.ndarray
    body_quat: np.ndarray
    body_vel: np.ndarray
    body_angmom: np.ndarray
    body_rot: np.ndarray
    body_dq: np.ndarray
    body_wrench: np.ndarray
    body_support: np.ndarray
    body_work: np.ndarray
    body_damp: np.ndarray
    body_reaction: np.ndarray
    spring_force: np.ndarray


class SpringHistory(NamedTuple):
    """The inelastic springs' history (physics/inelastic.py)."""
    spring_state: np.ndarray
    spring_dp: np.ndarray
    spring_kappa: np.ndarray
    spring_dmg: np.ndarray
    spring_wp: np.ndarray
    spring_wf: np.ndarray
    spring_rate: np.ndarray
    cell_chi: np.ndarray
    cell_wf: np.ndarray
    cell_moment: np.ndarray
    cell_sigma: np.ndarray
    cell_dep: np.ndarray


class PoissonSlots(NamedTuple):
    """The auxiliary stress of the Poisson correction (physics/poisson.py):
    per cell its links (slots), gains and λ V, and the scratch aux_g
    (n_slots, 3) [1/m], aux_p (7, N)."""
    cell_slot_ptr: np.ndarray
    slot_cell: np.ndarray
    slot_rev: np.ndarray
    slot_g: np.ndarray
    cell_c0: np.ndarray
    slot_s0: np.ndarray
    slot_s1: np.ndarray
    cell_lv: np.ndarray
    aux_g: np.ndarray
    aux_p: np.ndarray


class ContactArrays(NamedTuple):
    """Contact between any cells (physics/collide.py).  State: the
    candidate pairs (P, 2) int32, slip (P, 3) [m], sep (P,) int32, out
    (P, N_OUT), each body's pairs (ptr, entry), body_friction (N,) [J],
    body_dwrench (N, 6).  Geometry (model/contact.py ContactModel): the cells'
    faces, loops, vertices, planes, radius, size, moduli, rigid flags, the
    ground plane; mu, kfac, zeta scalars; scratch (threads, rows, 3);
    overwrite: the model has no springs (no spring pass clears the
    wrenches)."""
    pairs: np.ndarray
    slip: np.ndarray
    sep: np.ndarray
    out: np.ndarray
    ptr: np.ndarray
    entry: np.ndarray
    body_friction: np.ndarray
    body_dwrench: np.ndarray
    cell_face_ptr: np.ndarray
    loop_ptr: np.ndarray
    loop_xyz: np.ndarray
    face_plane: np.ndarray
    cell_loop_ptr: np.ndarray
    vert_ptr: np.ndarray
    vert_xyz: np.ndarray
    radius: np.ndarray
    body_size: np.ndarray
    body_e: np.ndarray
    body_g: np.ndarray
    body_rigid: np.ndarray
    ground: np.ndarray
    mu: float
    kfac: float
    zeta: float
    scratch: np.ndarray
    overwrite: bool


class ViscousSprings(NamedTuple):
    """Viscous springs (physics/viscous.py).  Per law row: law_dashpot (L,)
    [s] the dashpot's time τ_d (Kelvin's retardation time plus Rayleigh's
    β: the dashpot force τ_d k δ̇); law_g (L, M) the Maxwell branches'
    share g_i = E_i/E of the instantaneous modulus (0: no branch), law_a,
    law_b (L, M) their exact step factors exp(−dt/τ_i) and τ_i (1 − a)/dt
    for the run's dt; kelvin_a, kelvin_b (L,) the same factors of the
    dashpot time for a static run in time (the Kelvin spring integrated
    exactly; length 0 in a dynamic run: the dashpot's rate).  State per
    spring point: spring_state (the inelastic
    history's, or length 0: a broken spring carries no viscous force);
    spring_gap (S, 3) [m] the local gap (n, s, t) of the last pass;
    spring_q (S, M, 3) [N] the branches' forces; spring_fv (S, 3) [N] the
    viscous force of the last pass (local); spring_wv (S,) [J] its work so
    far; inv_dt [1/s]."""
    law_dashpot: np.ndarray
    law_g: np.ndarray
    law_a: np.ndarray
    law_b: np.ndarray
    kelvin_a: np.ndarray
    kelvin_b: np.ndarray
    spring_state: np.ndarray
    spring_gap: np.ndarray
    spring_q: np.ndarray
    spring_fv: np.ndarray
    spring_wv: np.ndarray
    inv_dt: float


class Relaxation(NamedTuple):
    """Dynamic relaxation (physics/relax.py): fict_mass (N,) [kg],
    fict_inertia (N,) [kg m²] the scaled masses; arm_length [m] of the
    moment residual; kind (ADAPTIVE, LOCAL) and beta of the damping;
    per iteration body_resid (N,), body_theta (N, 3) [rad], body_rprev
    (N, 6), body_num, body_den (N,)."""
    fict_mass: np.ndarray
    fict_inertia: np.ndarray
    arm_length: float
    kind: int
    beta: float
    body_resid: np.ndarray
    body_theta: np.ndarray
    body_rprev: np.ndarray
    body_num: np.ndarray
    body_den: np.ndarray


class Stepping(NamedTuple):
    """The explicit step: dt [s], mass-proportional damping α [1/s],
    Cundall's local damping β [1], and t0 [s]: step n is at time
    t0 + n dt (0 until a run changes its step, solvers/explicit.py)."""
    dt: float
    damping_alpha: float
    damping_local: float
    t0: float = 0.0


def of(cls, obj, **override):
    """An instance of container `cls` from the attributes of `obj` of the
    same names (model.Model, model.State), some given in `override`."""
    return cls(*(override[f] if f in override else getattr(obj, f) for f in cls._fields))


@nb.njit(cache=True)
def flag(x):
    """x as a run-time bool, not a constant (see module docstring)."""
    return bool(x)


class PlaneBodies(NamedTuple):
    """A plane model's bodies (physics/plane.py): body_mass (N,) [kg];
    body_jz (N,) [kg m²] polar moment about the centroid; body_pos0 (N+1, 2)
    [m] (row N: the ground)."""
    body_mass: np.ndarray
    body_jz: np.ndarray
    body_pos0: np.ndarray


class PlaneSprings(NamedTuple):
    """A plane model's spring points: spring_bodies (S, 2) int32;
    spring_arm_a, spring_arm_b (S, 2) [m] arms at rest (world axes);
    spring_slot (S,) int32; spring_area (S,) [m²]; face_n0 (F, 2) the rest
    normal from a to b; face_k (F, 2) [N/m³] (k_n, k_s) per area, k_s along
    e_z × n; face_h (F,) [m]; face_law (F,) int32; law_params (L,
    N_PARAMS); group_ptr, phase_ptr the schedule (partition.py);
    cell_ivol, cell_plane, cell_lever of continuum yield as in Springs."""
    spring_bodies: np.ndarray
    spring_arm_a: np.ndarray
    spring_arm_b: np.ndarray
    spring_slot: np.ndarray
    spring_area: np.ndarray
    face_n0: np.ndarray
    face_k: np.ndarray
    face_h: np.ndarray
    face_law: np.ndarray
    law_params: np.ndarray
    group_ptr: np.ndarray
    phase_ptr: np.ndarray
    cell_ivol: np.ndarray
    cell_plane: np.ndarray
    cell_lever: np.ndarray
    cell_k: np.ndarray
    cell_2g: np.ndarray


class PlaneLoads(NamedTuple):
    """A plane model's loads and constraints: body_fext (N, 3) [N, N, N m]
    dead (f_x, f_y, m_z); body_ffol (N, 3) or (0, 3) follower loads in the
    body's rest axes (they turn with it); body_load_hist (N,) int32;
    gravity (2,) [m/s²]; dof_kind (N, 3) int8, dof_value, dof_hist (N, 3)
    of (x, y, θ); amplitude tables hist_ptr, hist_t [s], hist_a; the
    ground's velocity table ground_hist (1,) int32 (−1: at rest) and
    direction ground_dir (2,)."""
    body_fext: np.ndarray
    body_ffol: np.ndarray
    body_load_hist: np.ndarray
    gravity: np.ndarray
    dof_kind: np.ndarray
    dof_value: np.ndarray
    dof_hist: np.ndarray
    hist_ptr: np.ndarray
    hist_t: np.ndarray
    hist_a: np.ndarray
    ground_hist: np.ndarray
    ground_dir: np.ndarray


class PlaneState(NamedTuple):
    """What changes per body of a plane model: body_pos (N+1, 2) [m];
    body_theta (N+1,) [rad] the rotation from rest (any number of turns);
    body_cs (N+1, 2) its (cos, sin); body_vel (N+1, 2) [m/s] and body_omega
    (N+1,) [rad/s] at the half step; body_wrench (N+1, 3) [N, N, N m];
    body_support (N+1, 2) [N]; body_work, body_damp (N,) [J]; body_reaction
    (N, 2) [N]; spring_force (S, 2) [N] (written when a pass is asked to
    `store`)."""
    body_pos: np.ndarray
    body_theta: np.ndarray
    body_cs: np.ndarray
    body_vel: np.ndarray
    body_omega: np.ndarray
    body_wrench: np.ndarray
    body_support: np.ndarray
    body_work: np.ndarray
    body_damp: np.ndarray
    body_reaction: np.ndarray
    spring_force: np.ndarray


class PlaneContact(NamedTuple):
    """Contact between any cells of a plane model (physics/plane_contact.py).
    State, the 3D contact's arrays (model/contact.py ContactState): pairs
    (P, 2) int32, slip (P, 3) [m] (z 0), sep (P,) int32 (a slab face row),
    out (P, N_OUT), each body's pairs (ptr, entry), body_friction (N,) [J],
    body_dwrench (N, 6) (columns 0, 1, 5).  Geometry: poly_ptr (N+1,),
    poly_xy (V, 2) [m] each cell's polygon counter-clockwise about its
    centroid in the world axes at rest; edge_face (V,) int32 the slab's side
    face of edge k (vertex k to k + 1), face_edge (F,) int32 its inverse
    (−1: a cap face); radius (N,) [m] about the centroid in the plane;
    body_size, body_e, body_g, body_rigid, ground (4,) n, d, mu, kfac, zeta
    as ContactArrays; thickness [m]; scratch (threads, rows, 3); overwrite:
    the model has no springs."""
    pairs: np.ndarray
    slip: np.ndarray
    sep: np.ndarray
    out: np.ndarray
    ptr: np.ndarray
    entry: np.ndarray
    body_friction: np.ndarray
    body_dwrench: np.ndarray
    poly_ptr: np.ndarray
    poly_xy: np.ndarray
    edge_face: np.ndarray
    face_edge: np.ndarray
    radius: np.ndarray
    body_size: np.ndarray
    body_e: np.ndarray
    body_g: np.ndarray
    body_rigid: np.ndarray
    ground: np.ndarray
    mu: float
    kfac: float
    zeta: float
    thickness: float
    scratch: np.ndarray
    overwrite: bool
