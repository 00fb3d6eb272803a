"""Model: the immutable structure-of-arrays of a run (bodies with real mass
and full principal inertia, spring points between neighbouring cells,
support springs to the ground (body index `n_bodies`), the face table,
laws, schedule, constraints, loads), as build.py builds it.  Kernels in
physics/ take these arrays; nothing here is read by a kernel as an object.

Index type: int32 throughout (DESIGN.md §5); state float64.
"""
import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..physics.rotation import quat_matrix_np
from .stable_step import omega_max_bound

IDX = np.int32


@dataclass(frozen=True)
class Model:
    """Static description of a run.  N bodies, S spring points.

    Bodies (rows 0..N-1; pos0/quat0 have one more row, the ground):
      body_mass (N,) [kg]; body_inertia (N, 3) principal moments [kg m²];
      body_volume (N,) [m³]; body_material (N,) int32;
      body_pos0 (N+1, 3) [m] centroids; body_quat0 (N+1, 4) principal axes.
    Springs:
      spring_bodies (S, 2) int32 (a, b), b == N for a support (ground);
      spring_arm_a, spring_arm_b (S, 3) [m] arms in the principal frames
      (the ground's frame is the world frame); spring_area (S,) [m²];
      spring_slot (S,) int32: the row of the spring's face in the face table.
    Face table (F rows, one per face that carries spring points, in spring
    order: what the points of one face share, held once):
      face_frame0 (F, 4) quaternion of the reference frame (n, s, t) with n
      from a to b; face_k (F, 3) [N/m³] stiffness per area (k_n, k_s, k_t);
      face_h (F,) [m] spring length; face_law (F,) int32 row of law_params;
      face_ref (F,) int32 internal face id, or −1 − boundary face id for
      supports.
    Per spring point, computed when asked (output, export, assembly; the
    kernels read the face table): spring_frame0 (S, 4), spring_k (S, 3)
      [N/m] = face_k × area, spring_h, spring_law, spring_face (S,),
      spring_point, spring_normal (= spring_n0) (S, 3): the rest position
      (on body a) and the frame's n.
    Spring laws (physics/laws/): face_law (spring_law) rows of law_params
      (n_laws, N_PARAMS) [Pa, 1, J/m²]; row 0 is purely elastic, row 1 + k
      is law slot k (a (material, part) pair in use: the fracture
      calibration depends on the part's mesh kind and cell size), row
      1 + K + k slot k without rupture (K slots; a support spring takes its
      cell's slot: a clamp can yield at the face, where beam theory puts
      the hinge; it breaks only when the support says `breakable: true`),
      then one row per interface with a law of its own (contact, or bonded
      with a material);
      spring_state0 (S,) int8 initial state (cuts: 2, broken);
      inelastic: bool, True when any law or cut needs the inelastic kernel.
    Schedule (partition.py): springs are stored by group, then (a, b);
      group_ptr (G+1,) spring ranges of the groups, phase_ptr (F+1,) group
      ranges of the phases (groups of a phase share no body).
    Constraints: dof_kind (N, 6) int8 (0 free, 1 fixed, 2 velocity, 3
      displacement), dof_value (N, 6), dof_hist (N, 6) int32.
    Loads: body_fext, body_mext (N, 3) [N, N m] world, fixed in space (dead);
      body_ffol, body_mfol (N, 3) [N, N m] follower loads in the body's
      principal frame (world R·f: they turn with the cell), (0, 3) when the
      case has none; body_load_hist (N,) int32 amplitude of both;
      gravity (3,) [m/s²]; amplitude tables hist_ptr, hist_t, hist_a.
    Plane models (plane "strain" or "stress"): the cells are prisms of the
      case's thickness about z = 0, their spring points on the mid-plane
      (mesh/spring_points.py edge_spring_points), z, rx, ry held in
      dof_kind; the explicit step runs the plane passes (physics/plane.py).
    Poisson correction (physics/poisson.py): poisson, a PoissonArrays of
      per-cell least-squares strain geometry and λ_c V_c; length 0 (and
      poisson_on False) when no material has an auxiliary λ.
    Mesh: mesh, the Mesh the model was built from (mesh/_core.py: cells'
      vertices and polygons, internal and boundary faces), which the build,
      the contact build, the history's static part and the probe plan
      read; the time loop reads none of it.  A run replaces it by a
      MeshSummary once its Recorder has written the geometry
      (without_mesh_arrays, cli/run.py): about 2.8 kB per Voronoi cell
      less while stepping.
    """
    n_bodies: int
    body_mass: np.ndarray
    body_inertia: np.ndarray
    body_volume: np.ndarray
    body_material: np.ndarray
    body_pos0: np.ndarray
    body_quat0: np.ndarray
    spring_bodies: np.ndarray
    spring_arm_a: np.ndarray
    spring_arm_b: np.ndarray
    spring_slot: np.ndarray
    spring_area: np.ndarray
    face_frame0: np.ndarray
    face_k: np.ndarray
    face_h: np.ndarray
    face_law: np.ndarray
    face_ref: np.ndarray
    group_ptr: np.ndarray
    phase_ptr: np.ndarray
    dof_kind: np.ndarray
    dof_value: np.ndarray
    dof_hist: np.ndarray
    body_fext: np.ndarray
    body_mext: np.ndarray
    body_ffol: np.ndarray
    body_mfol: np.ndarray
    body_load_hist: np.ndarray
    gravity: np.ndarray
    hist_ptr: np.ndarray
    hist_t: np.ndarray
    hist_a: np.ndarray
    groups: dict
    materials: list
    mesh: object = field(repr=False)
    n_cut: int = 0
    law_params: np.ndarray = None
    spring_state0: np.ndarray = None
    inelastic: bool = False
    poisson: object = None
    warnings: tuple = ()          # messages for the user (conflicting constraints, ...)
    contact: object = None        # contact.ContactModel, None: no contact
    plane: str = ""               # "strain" | "stress": a plane model (physics/plane.py); "": 3D
    # continuum yield (physics/laws/plastic.py; length 0 without it):
    # 1/V (N+1,) [1/m³] (0: the ground) and the plane-strain axis of a cell
    # of a one-cell-thick slab (N+1,) int8, −1 none (build.py _yield_field)
    cell_ivol: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cell_plane: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))
    cell_lever: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    # and each cell's shear strength k [Pa] and 2G [Pa] (build.py _yield_field)
    cell_k: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cell_2g: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # viscous springs (physics/viscous.py; length 0 without them): per law
    # row the dashpot time τ_d (L,) [s] (Kelvin's τ + Rayleigh's β) and the
    # Maxwell branches' shares g (L, M) of the instantaneous modulus and
    # times τ (L, M) [s] (laws.py viscous_laws)
    # the ground's motion (model/loads.py _ground_motion): its velocity's
    # amplitude table (1,) int32 (−1: the ground is at rest) and unit
    # direction (3,); the ground is the bodies' row N (physics/integrate.py)
    ground_hist: np.ndarray = field(default_factory=lambda: np.full(1, -1, dtype=np.int32))
    ground_dir: np.ndarray = field(default_factory=lambda: np.zeros(3))
    law_dashpot: np.ndarray = field(default_factory=lambda: np.zeros(0))
    law_branch_g: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    law_branch_tau: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def viscous(self):
        """True when the viscous-spring pass runs (physics/viscous.py)."""
        return self.law_dashpot.size > 0

    @property
    def n_branches(self):
        """Maxwell branches per spring point (physics/viscous.py)."""
        return self.law_branch_g.shape[1] if self.viscous else 0

    @property
    def poisson_on(self):
        """True when the auxiliary-stress pass runs (physics/poisson.py)."""
        return self.poisson is not None and len(self.poisson.slot_cell) > 0

    @property
    def spring_frame0(self):
        """(S, 4) reference frame quaternion of each spring point (its face's)."""
        return self.face_frame0[self.spring_slot]

    @property
    def spring_k(self):
        """(S, 3) [N/m] stiffness of each spring point: its face's per area × its area."""
        return self.face_k[self.spring_slot] * self.spring_area[:, None]

    @property
    def spring_h(self):
        """(S,) [m] length of each spring point (its face's)."""
        return self.face_h[self.spring_slot]

    @property
    def spring_law(self):
        """(S,) int32 law_params row of each spring point (its face's)."""
        return self.face_law[self.spring_slot]

    @property
    def spring_face(self):
        """(S,) int32 face of each spring point: internal face id, or −1 −
        boundary face id for a support."""
        return self.face_ref[self.spring_slot]

    @property
    def spring_normal(self):
        """(S, 3) unit normal of each spring point at rest (world): the
        first column of its frame.  Computed, not held (the kernels turn
        each face's frame once)."""
        return _frame_normals(self.spring_frame0)

    spring_n0 = spring_normal

    @property
    def spring_point(self):
        """(S, 3) rest position [m] of each spring point: body a's centroid
        plus its arm (the ground's frame is the world's).  Computed, not
        held (48 B per spring point with spring_normal; issue 15)."""
        # (the bodies' matrices once, then chunks of springs: no (S, 3, 3)
        # temporary, 560 MB at 200 000 cells)
        R = quat_matrix_np(self.body_quat0)
        a = self.spring_bodies[:, 0]
        out = np.empty((len(a), 3))
        for s0 in range(0, len(a), 1 << 18):
            s1 = min(s0 + (1 << 18), len(a))
            out[s0:s1] = self.body_pos0[a[s0:s1]] + np.einsum(
                "sij,sj->si", R[a[s0:s1]], self.spring_arm_a[s0:s1])
        return out

    @property
    def n_springs(self):
        return self.spring_bodies.shape[0]

    @property
    def ground(self):
        return self.n_bodies

    @property
    def is_support(self):
        return self.spring_bodies[:, 1] == self.n_bodies

    def without_mesh_arrays(self):
        """This model with `mesh` replaced by its MeshSummary (the counts,
        bounds and names, none of the geometry arrays): what a run steps
        once the Recorder has written the geometry to the history and taken
        its probe plan and surface levers (solvers/output.py).  The explicit
        and relaxation loops, checkpoints, restart and the end-of-run lines
        read no mesh array.  The memory is freed only when nothing else
        holds the Mesh (cli/run.py drops the build's model).  A model
        without a Mesh (None, or already a summary) is returned as it is."""
        if self.mesh is None or isinstance(self.mesh, MeshSummary):
            return self
        out = dataclasses.replace(self, mesh=MeshSummary.of(self.mesh))
        if "_stable_dt_ref" in self.__dict__:     # (the mesh is not in the bound)
            object.__setattr__(out, "_stable_dt_ref", self.__dict__["_stable_dt_ref"])
        return out

    def stable_dt(self, state=None):
        """Stable step 2/ω_max from a bound on ω_max² = λ_max(M⁻¹K): Gershgorin
        row sums of the mass-scaled small-strain stiffness M^-½ K M^-½, with
        the rotations of each body in its principal axes so that M is
        exactly diagonal (m, m, m, I1, I2, I3).  A similarity transform, so
        the bound is safe; it includes the shear-lever coupling of every
        spring (DESIGN.md §5) and is within a factor 2 of the true step on
        blocks, Voronoi and sliver meshes (tests/test_linear_modal.py,
        tests/test_stability.py); refined by omega_max_bound's sweeps.
        `state`: the bound of a deformed state (the levers to the springs'
        midpoints, which plastic and slip gaps lengthen; the step a run
        takes from there, solvers/explicit.py), else of the reference
        configuration: computed once per Model (its arrays are not changed
        after the build; dataclasses.replace makes a new Model, whose bound
        is computed anew): a run's checks, estimate and start ask for it
        four times, 4.6 s each at 200 000 cells."""
        if state is None and "_stable_dt_ref" in self.__dict__:
            return self.__dict__["_stable_dt_ref"]
        dt = self._stable_dt(state)
        if state is None:
            object.__setattr__(self, "_stable_dt_ref", dt)
        return dt

    def _stable_dt(self, state):
        lam = omega_max_bound(self, state=state)
        dt = np.inf if lam <= 0 else 2.0 / np.sqrt(lam)
        if self.viscous and np.isfinite(dt):
            # a dashpot τ_d k on the springs: the central difference is
            # stable for ω dt ≤ 2 (√(1 + ζ²) − ζ), ζ = τ_d ω/2 at ω_max
            # (Belytschko, Liu & Moran, Nonlinear FE, §6.3, stability with
            # damping; the same bound, by Jury's test, for the lagged rate
            # δ̇_{n−1/2} of physics/viscous.py)
            zeta = float(np.max(self.law_dashpot[np.unique(self.face_law)])) / dt
            dt *= np.sqrt(1.0 + zeta * zeta) - zeta
        return dt

@dataclass(frozen=True, eq=False)
class MeshSummary:
    """What a Model keeps of its Mesh while a run steps
    (Model.without_mesh_arrays): n_cells, box (2, 3) [m], surface_names and
    part_names.  The geometry arrays (vertices, polygons, internal and
    boundary faces: about 2.8 kB per Voronoi cell) are in the history by
    then (particles/bodies/geometry, springs/faces, springs/boundary_faces);
    reading one here raises an AttributeError that says so."""
    n_cells: int
    box: np.ndarray
    surface_names: tuple = ()
    part_names: tuple = ()

    @classmethod
    def of(cls, mesh):
        return cls(n_cells=int(mesh.n_cells), box=np.array(mesh.box, dtype=float),
                   surface_names=tuple(mesh.surface_names),
                   part_names=tuple(getattr(mesh, "part_names", ()) or ()))

    def __getattr__(self, name):
        # (only for names the summary lacks: a Mesh array, or a dunder
        # that copy and pickle look up)
        if name.startswith("__"):
            raise AttributeError(name)
        raise AttributeError(f"mesh.{name}: the mesh's arrays were released when the run "
                             "started stepping (Model.without_mesh_arrays); read what is "
                             "needed before (solvers/output.py Recorder)")

    def __repr__(self):
        lo, hi = self.box
        return f"MeshSummary({self.n_cells} cells, box {lo.tolist()}..{hi.tolist()})"


def _frame_normals(frame):
    """First column n of the rotation of each frame quaternion (S, 4) -> (S, 3)."""
    w, x, y, z = frame.T
    return np.ascontiguousarray(np.stack([1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z),
                                          2.0 * (x * z - w * y)], axis=1))
