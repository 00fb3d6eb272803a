"""Rigid parts in motion and interfaces under load (issue 12, items 5-7;
docs/case_file.md, "parts"): a free rigid part keeps its velocity and spin,
a rigid striker and a free block exchange momentum through an interface
and conserve it, a rigid platen driven on a column follows its prescribed
motion and reports the column's elastic (static) or impedance (dynamic)
force, a bonded interface with a material of its own breaks at that
material's strength, and check/info name each part and interface.

Every figure below is a formula of elasticity or a conservation law; each
tolerance is derived beside its assertion."""
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from rbsm_dyn.__main__ import main
from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_model
from rbsm_dyn.physics.rotation import quat_matrix_np

E, RHO, NU = 3.0e10, 2400.0, 0.0              # concrete-like, ν = 0: a clean 1D answer
C0 = np.sqrt(E / RHO)                        # bar wave speed, 3536 m/s
MATS = (f"c: {{density: {RHO}, young: {E}, poisson: {NU}}}\n"
        "  steel: {density: 7800, young: 2.0e11, poisson: 0.3}")


def model_of(text):
    return build_model(load_case_text(textwrap.dedent(text)))


def world_angular_momentum(h, k):
    """Σ (x × m v + R I Rᵀ ω) of frame k about the origin, and the sum of
    the magnitudes of its terms (the scale of its round-off)."""
    mass = h.static["particles/bodies/mass"]
    inertia = h.static["particles/bodies/inertia"]       # principal moments
    R = quat_matrix_np(h.orientation[k])                 # principal frame -> world
    spin = np.einsum("nij,nj,nkj,nk->ni", R, inertia, R, h.angular_velocity[k])
    orbit = np.cross(h.position[k], mass[:, None] * h.velocity[k])
    return (orbit + spin).sum(axis=0), np.abs(orbit).sum() + np.abs(spin).sum()


# ------------------------------------------------ a free rigid part ---

FREE = f"""
name: free
parts:
  block: {{geometry: {{box: [[0, 0, 0], [0.1, 0.1, 0.1]]}},
          mesh: {{kind: voronoi, size: 0.025, seed: 2}}, material: c}}
  striker: {{geometry: {{box: [[0.2, 0, 0], [0.26, 0.04, 0.02]]}}, mesh: {{kind: rigid}},
            material: steel}}
materials:
  {MATS}
initial: [{{group: striker, velocity: [-3.0, 1.5, 0.5], angular_velocity: [0, 0, 200.0]}}]
solver: {{mode: dynamic, end_time: 2.0e-4}}
output: {{interval: 2.0e-5, fields: [position, orientation, velocity, angular_velocity]}}
"""


def test_free_rigid_part_keeps_its_velocity_and_spin(run_case):
    """A rigid box (0.06 × 0.04 × 0.02, steel) thrown past a Voronoi block
    it does not touch (0.1 m apart: no interface, no spring between them),
    no gravity: no force acts on it, so v stays v0 and x = x0 + v0 t; it
    spins about its major principal axis z (I_z the largest moment: a
    steady, stable spin, Euler's equations), so ω stays ω0 and it has
    turned by ω0 t about z.  Round-off only: x0 + Σ v dt over 123 steps
    loses at most 123 ulp of 0.26 m (7e-15 m), so 1e-14 m; v and ω are
    never changed by a zero force (1e-12 relative); the angle 1e-12 rad.
    The total momentum Σ m v (the block at rest, its springs' forces
    summing to zero pair by pair) stays m v0 to 1e-12 of Σ |m v|."""
    h = run_case(FREE)
    m = model_of(FREE)
    i = int(m.groups["striker"][0])
    v0, w0 = np.array([-3.0, 1.5, 0.5]), np.array([0.0, 0.0, 200.0])
    t = h.time
    assert t[-1] >= 2.0e-4
    # at its geometric centroid, axes along the box's (I_z the largest)
    assert h.position[0, i] == pytest.approx([0.23, 0.02, 0.01], abs=1e-15)
    assert np.argmax(m.body_inertia[i]) == 2 and m.body_quat0[i] == pytest.approx([1, 0, 0, 0])
    assert np.abs(h.velocity[:, i] - v0).max() <= 1e-12 * np.linalg.norm(v0)
    assert np.abs(h.position[:, i] - (h.position[0, i] + v0 * t[:, None])).max() <= 1e-14
    assert np.abs(h.angular_velocity[:, i] - w0).max() <= 1e-12 * 200.0
    q = h.orientation[:, i]
    assert np.abs(q[:, 1:3]).max() <= 1e-15                   # still about z only
    angle = 2.0 * np.arctan2(q[:, 3], q[:, 0])
    assert np.abs(angle - 200.0 * t).max() <= 1e-12
    mass = h.static["particles/bodies/mass"]
    P = (mass[None, :, None] * h.velocity).sum(axis=1)
    scale = (mass[None, :, None] * np.abs(h.velocity)).sum(axis=1).max()
    assert np.abs(P - mass[i] * v0).max() <= 1e-12 * scale


# --------------------------------- a rigid striker on a free block ---

STRIKE = f"""
name: strike
parts:
  block: {{geometry: {{box: [[0, 0, 0], [0.1, 0.1, 0.1]]}},
          mesh: {{kind: voronoi, size: 0.025, seed: 2}}, material: c}}
  striker: {{geometry: {{box: [[0.02, 0.03, 0.1], [0.07, 0.08, 0.12]]}}, mesh: {{kind: rigid}},
            material: steel}}
interfaces: [{{parts: [block, striker], law: LAW}}]
materials:
  {MATS}
initial: [{{group: striker, velocity: [0.3, -0.2, -5.0], angular_velocity: [10.0, 0, 0]}}]
solver: {{mode: dynamic, end_time: 1.0e-4}}
output: {{interval: 5.0e-6, fields: [position, orientation, velocity, angular_velocity]}}
"""


@pytest.mark.parametrize("law", ["contact", "bonded"])
def test_rigid_striker_and_free_block_conserve_momentum(run_case, law):
    """A rigid striker (steel, 0.39 kg) resting on a free Voronoi block
    (concrete, 2.4 kg, no support, no gravity) thrown into it off-centre
    at 5 m/s with a spin, joined by a contact or a bonded interface.  The
    interface springs are the only forces, each an equal and opposite pair
    at one point (the rigid side's arm reaching the interface face), so
    the total linear momentum Σ m v and angular momentum
    Σ (x × m v + R I Rᵀ ω) stay at their initial values to round-off
    (1e-12 of the sum of the magnitudes of their terms; as
    tests/test_dynamics.py for one part).  The interface does act: the
    block takes more than half of the striker's momentum along z (its
    centre of mass moves at P_z/M_total in any case; a stiff elastic
    impact on a 6 times heavier block turns the striker back)."""
    h = run_case(STRIKE.replace("LAW", law))
    m = model_of(STRIKE.replace("LAW", law))
    i = int(m.groups["striker"][0])
    mass = h.static["particles/bodies/mass"]
    mv = mass[None, :, None] * h.velocity
    P = mv.sum(axis=1)
    assert P[0] == pytest.approx(mass[i] * np.array([0.3, -0.2, -5.0]), rel=1e-15)
    assert np.abs(P - P[0]).max() <= 1e-12 * np.abs(mv).sum(axis=1).max()
    J0, _ = world_angular_momentum(h, 0)
    for k in range(h.frames):
        J, scale = world_angular_momentum(h, k)
        assert np.abs(J - J0).max() <= 1e-12 * scale, k
    block = m.groups["block"]
    assert -mv[-1, block, 2].sum() > 0.5 * mass[i] * 5.0
    vz = h.velocity[:, i, 2]
    back = np.flatnonzero(vz > 0.0)
    assert len(back) > 0                                      # the striker is turned back
    if law == "contact":
        # compression only: once it has left the block nothing acts on it,
        # its velocity is constant (to round-off)
        assert vz[-1] > 0.0
        assert np.abs(h.velocity[-5:, i] - h.velocity[-1, i]).max() <= 1e-12 * 5.0
    else:
        # the bonded joint carries tension: it pulls the striker back down
        assert vz[back[0]:].min() < -0.5


# ------------------------------------------- a rigid platen on a column ---

COLUMN = f"""
name: column
parts:
  column: {{geometry: {{box: [[0, 0, 0], [0.05, 0.05, 0.2]]}}, mesh: MESH, material: c}}
  platen: {{geometry: {{box: [[-0.01, -0.01, 0.2], [0.06, 0.06, 0.22]]}}, mesh: {{kind: rigid}},
           material: steel}}
interfaces: [{{parts: [column, platen], law: LAW}}]
materials:
  {MATS}
boundary:
  - {{surface: column.zmin, fix: all}}
  - {{group: platen, fix: [x, y, rx, ry, rz]}}
  - {{group: platen, MOTION}}
SOLVER
output:
  probes:
    R: {{group: platen, quantity: reaction, component: z, reduce: sum}}
    u: {{group: platen, quantity: displacement, component: z, reduce: sum}}
    base: {{surface: column.zmin, quantity: reaction, component: z, reduce: sum}}
"""
BLOCKS = "{kind: blocks, divisions: [2, 2, 8]}"
VORONOI = "{kind: voronoi, size: 0.0125, seed: 4}"
A, L = 0.05 * 0.05, 0.2                       # column section [m²] and height [m]


@pytest.mark.parametrize("law, mesh, rel", [
    # blocks: springs in series along z, h = half a block at the support,
    # a whole block inside, half a block at the platen (its rigid side adds
    # nothing): the chain's compliance is L/(EA) exactly (E0 = E for blocks,
    # docs/case_file.md "materials"); the elastic predictor solves K U = F
    # directly and the residual tolerance (1e-6) bounds what is left
    ("bonded", BLOCKS, 1e-6),
    # a contact interface carries compression at the same stiffness
    ("contact", BLOCKS, 1e-6),
    # Voronoi: E of the calibrated lattice (docs/calibration.md) of a column
    # only 4 cells across: 3 %, as the Lamé and beam checks
    ("bonded", VORONOI, 3e-2),
])
def test_rigid_platen_compresses_a_column_statically(run_case, law, mesh, rel):
    """A column (0.05 × 0.05 × 0.2, ν = 0, fixed at its base) under a rigid
    steel platen joined by a bonded or a contact interface, the platen
    driven down by δ = 20 µm in two load steps (static).  The platen moves
    by exactly λ δ (its coordinate 0.21 m moved: 1e-15 m, a few ulp), and
    the reaction it reports is the column's elastic force E A δ / L
    (7500 N), pushing it up; the base carries the same force (static
    equilibrium, to the same tolerance)."""
    d = 2.0e-5
    h = run_case(COLUMN.replace("MESH", mesh).replace("LAW", law)
                 .replace("MOTION", f"displacement: [null, null, {-d}]")
                 .replace("SOLVER", "solver: {mode: static, load_steps: 2}"))
    ob = h.observables
    assert np.abs(ob["u"] - np.array([0.0, -0.5 * d, -d])).max() <= 1e-15
    F = E * A * d / L
    # the reaction is the force the prescription applies to the platen: down
    assert -ob["R"][-1] == pytest.approx(F, rel=rel)
    assert -ob["R"][1] == pytest.approx(0.5 * F, rel=rel)          # linear in λ
    assert ob["base"][-1] == pytest.approx(-ob["R"][-1], rel=1e-6)


@pytest.mark.parametrize("law", ["contact", "bonded"])
def test_rigid_platen_driven_at_constant_velocity(run_case, law):
    """The same block column (40 blocks of 5 mm along z, one across) hit by
    the platen driven down at v = 0.1 m/s from t = 0 (dynamic, 100 µs).
    The platen's displacement is −v t at every frame (x0 + Σ v dt: 130
    steps, each at most an ulp of 0.21 m: 1e-14 m).  Before the wave that
    starts at the platen returns (t < 2L/c0 = 113 µs) the platen drives a
    semi-infinite bar: its reaction is the bar's impedance force
    ρ c0 A v = A v √(Eρ) (2121 N; e.g. Graff, Wave Motion in Elastic
    Solids, §2.1).  The lattice rings about it (±16 % at first, decaying
    as the dispersive front leaves), so the mean over t in [0.3, 1.9] L/c0
    (several ringing periods) is within 2 %.  The base feels nothing until
    the front arrives at L/c0 (long waves travel at c0; the lattice's
    dispersive front spreads a little ahead of them, so the base is quiet,
    below 1e-3 of the impedance force, until 0.8 L/c0), then the fixed end
    doubles it:
    2 ρ c0 A v (mean over [1.2, 1.75] L/c0, before the reflection reaches
    the platen at 2L/c0; within 5 %: the ringing again)."""
    v = 0.1
    h = run_case(COLUMN.replace("MESH", "{kind: blocks, divisions: [1, 1, 40]}")
                 .replace("LAW", law).replace("MOTION", f"velocity: [null, null, {-v}]")
                 .replace("SOLVER", "solver: {mode: dynamic, end_time: 1.0e-4}")
                 .replace("output:", "output:\n  interval: 1.0e-6"))
    t, ob = h.time, h.observables
    assert t[-1] >= 1.0e-4
    assert np.abs(ob["u"] + v * t).max() <= 1e-14
    Z = A * v * np.sqrt(E * RHO)
    T = L / C0
    window = (t >= 0.3 * T) & (t <= 1.9 * T)
    assert -ob["R"][window].mean() == pytest.approx(Z, rel=2e-2)
    assert np.abs(ob["base"][t <= 0.8 * T]).max() < 1e-3 * Z
    window = (t >= 1.2 * T) & (t <= 1.75 * T)
    assert ob["base"][window].mean() == pytest.approx(2.0 * Z, rel=5e-2)


# ------------------------------------ a bonded joint of its own material ---

FT_M, GF_M = 2.0e6, 100.0          # mortar: tensile strength [Pa], fracture energy [J/m²]
E_M = 3.0e9                        # mortar: a tenth of the parts' modulus
L_EFF = 0.375                      # support face (x = 0) to the pulled cells' centroids
A_JOINT = 0.05 * 0.05              # the bar's section [m²]
JOINT = f"""
name: joint
parts:
  a: {{geometry: {{box: [[0, 0, 0], [0.2, 0.05, 0.05]]}}, mesh: {{kind: blocks, divisions: [4, 1, 1]}},
      material: c}}
  b: {{geometry: {{box: [[0.2, 0, 0], [0.4, 0.05, 0.05]]}}, mesh: {{kind: blocks, divisions: [4, 1, 1]}},
      material: c}}
interfaces: [{{parts: [a, b], law: bonded, material: mortar}}]
materials:
  c: {{density: {RHO}, young: {E}, poisson: 0.0,
      rupture: {{fracture_energy: 300.0, tensile_strength: {3 * FT_M}}}}}
  mortar: {{density: 2000, young: {E_M}, poisson: 0.0,
           rupture: {{fracture_energy: {GF_M}, tensile_strength: {FT_M}}}}}
boundary:
  - {{surface: a.xmin, fix: all}}
  - {{group: all, fix: [y, z, rx, ry, rz]}}
  - {{surface: b.xmax, displacement: [U, null, null]}}
solver: {{mode: static, method: newton, load_steps: 24}}
output:
  fields: [position, spring_state]
  probes:
    R: {{surface: a.xmin, quantity: reaction, component: x, reduce: sum}}
"""


def test_bonded_joint_breaks_at_its_own_materials_strength(run_case):
    """Two block bars (E = 30 GPa, f_t = 6 MPa) bonded at x = 0.2 by a
    'mortar' interface material (f_t,m = 2 MPa, G_f,m = 100 J/m²,
    E_m = 3 GPa), pulled along x (1D: lateral motion and rotations held),
    static by Newton.  The documented contract (docs/case_file.md,
    "parts"): the interface faces become springs "as between two cells of
    one part" (k_n = 1/(h_a/E + h_b/E), the parts' moduli) carrying "the
    law of `material`" (its yield and rupture; a law row holds no modulus,
    physics/laws/__init__.py), so:
    * the bar's stiffness is the one-part bar's, E A / L_eff (L_eff =
      0.375 from the support face to the pulled cells' centroids: springs
      in series, exact for blocks), E_m not entering: 1e-6 (Newton's
      tolerance; the step is elastic);
    * the peak load is f_t,m A (5000 N), the mortar's, not the parts'
      3 f_t,m A: blocks take f_t at their springs unscaled (F_T = 1,
      docs/calibration.md "Fracture"), a uniaxial bar puts σ = F/A on every
      spring, and the 24 load steps of u_p/4 (u_p = f_t,m L_eff/E) land on
      the peak: 1e-6;
    * the crack is the interface: every broken spring lies at x = 0.2,
      every spring of the parts intact;
    * it dissipates G_f,m A (blocks: F_G = 1) within 1 %: the energy is
      booked over load steps, and the one that crosses the end of softening
      (opening step Δw = u_p/3, the bar's elastic recovery adding a third)
      starts from at most f_t A Δw/w_c, w_c = 2 G_f/f_t = 4 u_p: a
      trapezoid error of at most ½ Δw f_t A Δw/w_c = f_t A u_p/72 against
      G_f A = 2 f_t A u_p, i.e. 0.7 %."""
    u_p = FT_M * L_EFF / E
    h = run_case(JOINT.replace("U", repr(6.0 * u_p)))
    R = -h.observables["R"]                    # the support pulls back: R < 0
    # elastic steps: λ = 1/24, 2/24, 3/24 of 6 u_p
    u = 6.0 * u_p * h.time
    for k in (1, 2, 3):
        assert R[k] == pytest.approx(E * A_JOINT * u[k] / L_EFF, rel=1e-6)
    assert R.max() == pytest.approx(FT_M * A_JOINT, rel=1e-6)
    assert R[-1] == pytest.approx(0.0, abs=1e-6 * FT_M * A_JOINT)      # fully separated
    state = h.series["springs/state"][-1]
    x = h.static["springs/position"][:, 0]
    support = h.static["springs/support"].astype(bool)
    broken = (state >= 2) & ~support
    assert broken.any()
    assert np.all(np.abs(x[broken] - 0.2) < 1e-12)
    assert np.all(state[~support & (np.abs(x - 0.2) > 1e-9)] == 0)
    assert h.observables["fracture"][-1] == pytest.approx(GF_M * A_JOINT, rel=1e-2)


def test_a_bonded_layer_of_given_thickness_adds_its_compliance(run_case):
    """The same bar with the mortar as a layer of thickness t = 10 mm
    (`thickness`): springs in series, 1/K = L_eff/(E A) + t/(E_m A)
    (ν = 0: a block spring's modulus is E, docs/calibration.md), exact for
    blocks up to Newton's tolerance (1e-6); an elastic step (u = u_p/2)."""
    t = 0.01
    u_p = FT_M * L_EFF / E
    text = (JOINT.replace("U", repr(0.5 * u_p)).replace("load_steps: 24", "load_steps: 1")
            .replace("material: mortar}", f"material: mortar, thickness: {t}}}"))
    R = -run_case(text).observables["R"]
    K = 1.0 / (L_EFF / (E * A_JOINT) + t / (E_M * A_JOINT))
    assert R[-1] == pytest.approx(K * 0.5 * u_p, rel=1e-6)
    # (without the layer the bar is E A / L_eff: 1.27 times stiffer here)


# ---------------------------------------------- check and info name parts ---

SCENE = """\
name: scene
parts:
  slab: {geometry: {box: [[0, 0, 0], [0.2, 0.1, 0.05]]},
         mesh: {kind: voronoi, size: 0.025, seed: 5}, material: c}
  pad: {geometry: {box: [[0.05, 0.02, 0.05], [0.15, 0.12, 0.07]]},
        mesh: {kind: blocks, divisions: [4, 4, 1]}, material: c}
interfaces: [{parts: [slab, pad], law: contact, friction: 0.3}]
materials:
  c: {density: 2400, young: 3.0e10, poisson: 0.0}
boundary: [{surface: slab.zmin, fix: all}]
solver: {mode: dynamic, end_time: 1.0e-5}
"""
PART_LINE = re.compile(r"part (\w+) \((\w+), (\w+)\): (\d+) bodies, volume (\S+) m³")
IFACE_LINE = re.compile(r"interface (\w+)–(\w+) \((\w+)\): (\d+) faces, (\S+) m²")


def test_check_and_info_name_each_part_and_interface(tmp_path, capsys):
    """`python -m rbsm_dyn check` (and `info`) on a Voronoi slab under a
    block pad that overhangs it: one line per part with its mesh kind,
    material, the bodies of its group and its volume, one per interface
    with its faces and area.  Facts: the pad is 4 × 4 × 1 = 16 blocks, the
    parts' bodies add up to the model's; their volumes are the boxes'
    (0.001 and 0.0002 m³; cells sum to the solid's volume to 1e-9, printed
    to 6 digits: 5e-7); the pad overhangs the slab by 0.02 m in y, so they
    touch over [0.05, 0.15] × [0.02, 0.1] = 0.008 m²: the model's interface
    faces sum to it within 1e-9 (overlap polygons, docs/case_file.md), and
    the line prints it (6 digits); every pad block touches the slab (its
    y-range starts below 0.1), so each is in at least one interface face."""
    case = tmp_path / "scene.yaml"
    case.write_text(SCENE, encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "rbsm_dyn", "check", str(case)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    m = model_of(SCENE)
    fi = m.mesh.face_interface
    on = fi == 0
    area = m.mesh.face_area[on].sum()
    assert area == pytest.approx(0.1 * 0.08, rel=1e-9)
    pad = m.groups["pad"]
    assert len(pad) == 16
    assert set(m.mesh.face_cells[on].ravel()) >= set(pad.tolist())
    assert len(m.groups["slab"]) + len(pad) == m.n_bodies
    main(["info", str(case)])
    for out in (r.stdout, capsys.readouterr().out):
        parts = {g[0]: g[1:] for g in PART_LINE.findall(out)}
        assert set(parts) == {"slab", "pad"}
        for name, kind, volume in (("slab", "voronoi", 0.2 * 0.1 * 0.05),
                                   ("pad", "blocks", 0.1 * 0.1 * 0.02)):
            k, mat, n, v = parts[name]
            assert (k, mat) == (kind, "c")
            assert int(n) == len(m.groups[name])
            assert float(v) == pytest.approx(volume, rel=5e-7)
        ifaces = IFACE_LINE.findall(out)
        assert len(ifaces) == 1
        a, b, law, faces, shown = ifaces[0]
        assert (a, b, law) == ("slab", "pad", "contact")
        assert int(faces) == int(on.sum()) >= 16
        assert float(shown) == pytest.approx(0.1 * 0.08, rel=5e-7)
