"""Contact between any cells (issue 16, DESIGN.md §8, physics/collide.py):
a striker on a free bar (VERIFICATION D2), a block sliding on the ground
(F3) with contact found by the broad phase, a tall block on a tilted plane
that topples or slides, a block dropped on a block, a shattering block whose
fragments never pass through each other, and the checks on the case key.

Every figure is a formula of mechanics or a conservation law; each
tolerance is derived beside its assertion."""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text
from rbsm_dyn.model import build_model
from rbsm_dyn.physics.contact_geometry import SCRATCH_ROWS, overlap
from rbsm_dyn.physics.rotation import quat_matrix_np

G = 9.81


# ------------------------------------------------- D2: bar impact ---

RHO, E, V0, L, A = 8000.0, 2.0e11, 10.0, 0.2, 1.0e-4
C0 = np.sqrt(E / RHO)                                   # 5000 m/s
D2 = f"""
name: d2
parts:
  striker: {{geometry: {{box: [[-0.200001, 0, 0], [-0.000001, 0.01, 0.01]]}},
            mesh: {{kind: blocks, divisions: [20, 1, 1]}}, material: steel}}
  bar: {{geometry: {{box: [[0, 0, 0], [0.2, 0.01, 0.01]]}},
        mesh: {{kind: blocks, divisions: [20, 1, 1]}}, material: steel}}
materials:
  steel: {{density: {RHO}, young: {E}, poisson: 0.0}}
initial: [{{group: striker, velocity: [{V0}, 0, 0]}}]
contact: {{between: [striker, bar]}}
solver: {{mode: dynamic, end_time: 1.2e-4}}
output: {{interval: 5.0e-7, fields: [position, velocity]}}
"""


def test_D2_bar_impact(run_case):
    """VERIFICATION D2: an identical striker at v on a free bar (steel,
    ν = 0, L = 0.2 m, 1 cm² section, 20 blocks each, 1 µm apart): the
    contact stress is ρ c0 v/2 = 200 MPa for 2L/c0 = 80 µs; the striker
    stops, the bar leaves at v.  The plateau mean (the bar's momentum
    gained over the middle 80 % of the contact, over A × that time) and the
    contact time within 3 % (VERIFICATION's
    2–3 %; a chain of 20 blocks rings about the mean, and the contact time
    is resolved to one frame, 0.6 %); the bar at ≥ 97 % of v and the
    striker at ≤ 3 % (the chain keeps a little vibration; the continuum
    answer is exact).  Momentum: contact forces are equal and opposite at
    one point, so Σ m v is m v0 to round-off (1e-12).  Energy: kinetic +
    strain (springs and contact) = ½ m v0² within 1 % at every frame."""
    h = run_case(D2)
    m = h.static["particles/bodies/mass"]
    v = h.velocity[:, :, 0]
    bar = h.position[0, :, 0] > 0
    p_bar = (m[bar] * v[:, bar]).sum(axis=1)
    p_all = (m[:, None] * v.T).sum(axis=0)
    assert np.all(np.abs(p_all - m[~bar].sum() * V0) <= 1e-12 * m.sum() * V0)
    # contact from the first frame the bar moves to the last it speeds up
    moving = np.nonzero(np.abs(np.diff(p_bar)) > 1e-9 * p_bar[-1])[0]
    t = h.time
    t_contact = t[moving[-1] + 1] - t[moving[0]]
    assert t_contact == pytest.approx(2 * L / C0, rel=0.03)
    # the plateau: the middle 80 % of the contact (the rise and the tail,
    # one or two cells' transit each, left out)
    t0 = t[moving[0]]
    i1, i2 = np.searchsorted(t, [t0 + 0.1 * t_contact, t0 + 0.9 * t_contact])
    sigma = (p_bar[i2] - p_bar[i1]) / (A * (t[i2] - t[i1]))
    assert sigma == pytest.approx(RHO * C0 * V0 / 2, rel=0.03)           # 200 MPa
    assert p_bar[-1] / m[bar].sum() >= 0.97 * V0
    assert abs((m[~bar] * v[-1, ~bar]).sum() / m[~bar].sum()) <= 0.03 * V0
    eb = h.energy_balance()
    assert np.max(np.abs(eb["error"])) <= 0.01 * 0.5 * m[~bar].sum() * V0 ** 2


# ------------------------------------------ F3: sliding on the ground ---

def block_on_ground(gravity, mu, size=(0.1, 0.1, 0.05), end=1.0, extra=""):
    bx, by, bz = size
    return f"""
    name: slide
    parts:
      block: {{geometry: {{box: [[0, 0, 0], [{bx}, {by}, {bz}]]}}, mesh: {{kind: rigid}},
              material: m}}
    materials:
      m: {{density: 2000, young: 1.0e9, poisson: 0.2}}
    loads: [{{gravity: [{float(gravity[0])!r}, 0, {float(gravity[2])!r}]}}]
    contact: {{friction: {mu}, damping: 0.3, ground: {{point: [0, 0, 0], normal: [0, 0, 1]}}}}
    solver: {{mode: dynamic, end_time: {end}}}
    output: {{interval: 0.01, fields: [position, orientation, velocity]}}
    {extra}
    """


def turned_deg(h):
    """(T,) angle [deg] each frame's orientation has turned from the first."""
    q = h.orientation[:, 0]
    return np.degrees(2 * np.arccos(np.minimum(1.0, np.abs((q * q[0]).sum(axis=1)))))


def test_F3_incline_broad_phase(run_case):
    """VERIFICATION F3 on the ground plane, the contact found by the broad
    phase (no spring joins the block to anything): θ = 30°, μ = 0.2 →
    a = g (sin θ − μ cos θ) = 3.2059 m/s², 1.6029 m after 1 s, within 1 %
    (VERIFICATION's tolerance); the block does not turn (0.1°: the
    penalty's rocking) and the energy balance closes to 0.1 % of the work
    of gravity (friction booked as contact_friction)."""
    th = np.radians(30.0)
    g = (G * np.sin(th), 0.0, -G * np.cos(th))
    h = run_case(block_on_ground(g, 0.2))
    a = G * (np.sin(th) - 0.2 * np.cos(th))
    assert a == pytest.approx(3.2059, abs=1e-4)                          # VERIFICATION F3
    x = h.position[-1, 0, 0] - h.position[0, 0, 0]
    assert x == pytest.approx(0.5 * a * h.time[-1] ** 2, rel=0.01)
    assert turned_deg(h).max() < 0.1
    eb = h.energy_balance()
    assert np.max(np.abs(eb["error"])) <= 1e-3 * np.max(np.abs(eb["supplied"]))
    assert h.observables["contact_friction"][-1] > 0


def test_F3_horizontal_slide_stops_and_stays(run_case):
    """F3: v0 = 5 m/s on level ground, μ = 0.3 → stops after v0²/(2 μ g) =
    4.2474 m within 1 %; then no creep: under 1 µm over the rest of the run
    (the stuck slip spring holds)."""
    h = run_case(block_on_ground((0.0, 0.0, -G), 0.3, end=2.0,
                                 extra="initial: [{group: block, velocity: [5, 0, 0]}]"))
    x = h.position[:, 0, 0] - h.position[0, 0, 0]
    assert 25.0 / (2 * 0.3 * G) == pytest.approx(4.2474, abs=1e-4)        # VERIFICATION F3
    assert x[-1] == pytest.approx(4.2474, rel=0.01)
    stop = int(np.argmax(h.time > 5.0 / (0.3 * G) * 1.05))   # past 1.05 × the stop time
    assert np.ptp(x[stop:]) < 1e-6


# ------------------------------------------------- a tilting block ---

@pytest.mark.parametrize("mu, deg, topples, slides", [
    (0.5, 17.0, False, False),     # below atan(b/h) = 18.43° and atan μ = 26.6°: stays
    (0.5, 20.0, True, False),      # past atan(b/h), below atan μ: topples
    (0.25, 16.0, False, True),     # past atan μ = 14.04°, below atan(b/h): slides
])
def test_tilting_block_topples_or_slides(run_case, mu, deg, topples, slides):
    """A rigid block b = 0.1 (along the slope) × h = 0.3 on a plane tilted
    by θ (gravity turned by θ): it topples when the weight's line leaves
    the base, tan θ > b/h (θ > 18.43°), and slides when tan θ > μ; with
    μ = 0.5 it topples first, with μ = 0.25 it slides first.  Over 1 s: a
    toppling block has turned past 45° (it falls on its side); one that
    does not stays within 1° (the penalty's rocking); a sliding one has
    moved at least half of ½ g (sin θ − μ cos θ) t², one that does not
    under 1 mm."""
    th = np.radians(deg)
    h = run_case(block_on_ground((G * np.sin(th), 0.0, -G * np.cos(th)), mu,
                                 size=(0.1, 0.1, 0.3)))
    turn = turned_deg(h).max()
    assert (turn > 45.0) if topples else (turn < 1.0)
    if not topples:
        x = h.position[-1, 0, 0] - h.position[0, 0, 0]
        a = G * (np.sin(th) - mu * np.cos(th))
        assert (x > 0.25 * a * h.time[-1] ** 2) if slides else (abs(x) < 1e-3)


# ---------------------------------------------- a block on a block ---

DROP = """
name: drop
parts:
  base: {geometry: {box: [[0, 0, 0], [0.1, 0.1, 0.05]]}, mesh: {kind: blocks, divisions: [2, 2, 1]},
         material: m}
  top: {geometry: {box: [[0.025, 0.025, 0.055], [0.075, 0.075, 0.105]]}, mesh: {kind: rigid},
        material: m}
materials:
  m: {density: 2000, young: 1.0e9, poisson: 0.2}
boundary: [{surface: base.zmin, fix: all}]
loads: [{gravity: [0, 0, -9.81]}]
contact: {between: [base, top], damping: 0.5}
solver: {mode: dynamic, end_time: 0.3}
output: {interval: 0.002, fields: [position, velocity]}
"""


def test_block_dropped_on_a_block_lands_and_stays(run_case):
    """A rigid 5 cm cube dropped 5 mm onto a 2 × 2 block base fixed at its
    foot (contact damping ζ = 0.5: restitution e = exp(−πζ/√(1−ζ²)) =
    0.16, so it settles in a few bounces).  No tunnelling: its centre never
    goes below the base's top by more than its half-height plus 10 % of the
    cube.  At rest (last third of the run): it moves less than the static
    deflection of its contact, m g / k with k = E A/(l_base/2) per the two
    half-cells in series (the base's cells, the cube rigid), plus the
    base's own compression m g h/(E A_base) (it sits on four cells)."""
    h = run_case(DROP)
    m = build_model(load_case_text(DROP))
    i = int(m.groups["top"][0])
    z = h.position[:, i, 2]
    mass = h.static["particles/bodies/mass"][i]
    assert z.min() >= 0.05 + 0.025 - 0.1 * 0.05
    k_contact = 1.0e9 * 0.05 ** 2 / 0.025                   # E A / l, l = 0.05/2
    d_static = mass * G / k_contact + mass * G * 0.05 / (1.0e9 * 0.1 ** 2)
    rest = z[2 * len(z) // 3:]
    assert np.ptp(rest) <= d_static
    assert abs(rest.mean() - 0.075) <= 3 * d_static


# ------------------------------------------ a shattering block ---

SHATTER = """
name: shatter
domain: {box: [[0, 0, 0.001], [0.1, 0.1, 0.101]]}
mesh: {kind: voronoi, size: 0.02, seed: 3}
materials:
  glass: {density: 2500, young: 7.0e10, poisson: 0.2,
          rupture: {fracture_energy: 8.0, tensile_strength: 4.0e7}, friction: 0.3}
initial: [{velocity: [0, 0, -30]}]
contact: {between: all, friction: 0.3, ground: {point: [0, 0, 0], normal: [0, 0, 1]}}
solver: {mode: dynamic, end_time: 4.0e-4}
output: {interval: 1.0e-5, fields: [position, orientation, velocity]}
"""


def test_shattering_block_fragments_never_overlap(run_case):
    """A 10 cm Voronoi glass block (125 cells of ~2 cm) thrown at 30 m/s
    onto the ground shatters (most springs broken).  Fragments that were
    never neighbours meet only through contact: at every frame no such pair
    overlaps by a mean depth V/A over 10 % of the cell size (issue 16), and
    the energy balance closes within 2 % of the kinetic energy supplied."""
    h = run_case(SHATTER)
    m = build_model(load_case_text(SHATTER))
    assert h.observables["n_broken"][-1] > 0.5 * m.n_springs
    eb = h.energy_balance()
    assert np.max(np.abs(eb["error"])) <= 0.02 * eb["supplied"][0]
    cm = m.contact
    n = m.n_bodies
    nbr = set(map(tuple, m.spring_bodies[m.spring_bodies[:, 1] < n].tolist()))
    rows = int(np.max(np.diff(cm.cell_loop_ptr)))
    faces = int(np.max(np.diff(cm.cell_face_ptr)))
    scratch = np.zeros((SCRATCH_ROWS(rows, faces), 3))
    worst = 0.0
    for k in range(len(h.time)):
        x = h.position[k]
        R = quat_matrix_np(h.orientation[k])
        d = np.linalg.norm(x[:, None] - x[None], axis=2)
        close = np.argwhere(np.triu(d <= cm.radius[:, None] + cm.radius[None], 1))
        for a, b in close:
            if (a, b) in nbr:
                continue
            vol, *_, area = overlap(a, x[a], R[a], b, x[b], R[b], cm.cell_face_ptr,
                                    cm.loop_ptr, cm.loop_xyz, cm.face_plane, cm.radius,
                                    scratch)
            if area > 0:
                worst = max(worst, vol / area)
    assert worst <= 0.1 * 0.02


# --------------------------------------------------- the case key ---

def test_contact_key_is_checked():
    """contact in a static run, an unknown part, an empty list and a zero
    ground normal are refused with the key named."""
    base = """
    name: c
    parts:
      a: {geometry: {box: [[0, 0, 0], [1, 1, 1]]}, mesh: {kind: blocks, divisions: [1, 1, 1]},
          material: m}
    materials: {m: {density: 1000, young: 1.0e9, poisson: 0.2}}
    """
    dyn = "solver: {mode: dynamic, end_time: 1.0e-3}\n"
    cases = {
        "contact: {}\nsolver: {mode: static}\n": "contact acts in solver.mode dynamic only",
        "contact: {between: [a, b]}\n" + dyn: "unknown part 'b'",
        "contact: {between: []}\n" + dyn: "must not be empty",
        "contact: {ground: {normal: [0, 0, 0]}}\n" + dyn: "must not be the zero vector",
        "contact: {friction: -1}\n" + dyn: "friction",
    }
    for tail, message in cases.items():
        with pytest.raises(CaseError, match=message):
            load_case_text(textwrap.dedent(base) + tail)


def test_contact_results_identical_for_any_thread_count(run_case):
    """The pair forces are independent and each body sums its pairs in
    pair order (physics/collide.py): the shattering block's last frame is
    bitwise the same on 1 and 2 threads."""
    one = run_case(SHATTER, "--threads", "1")
    two = run_case(SHATTER, "--threads", "2")
    assert np.array_equal(one.position[-1], two.position[-1])
    assert np.array_equal(one.velocity[-1], two.velocity[-1])
    assert np.array_equal(one.observables["contact_friction"],
                          two.observables["contact_friction"])


# ------------------------------- a rigid striker without a contact key ---

STRIKE = """
name: strike
parts:
  block: {geometry: {box: [[0, 0, 0], [0.1, 0.05, 0.05]]}, mesh: {kind: blocks, divisions: [4, 2, 2]},
          material: c}
  striker: {geometry: {box: [[-0.0501, 0.0, 0.0], [-0.0001, 0.05, 0.05]]}, mesh: {kind: rigid},
            material: c}
materials:
  c: {density: 2400, young: 3.0e10, poisson: 0.2}
initial: [{group: striker, velocity: [5.0, 0, 0]}]
solver: {mode: dynamic, end_time: 2.0e-4}
output: {interval: 2.0e-6, fields: [position, velocity]}
"""


def test_rigid_striker_gets_contact_without_the_key(run_case):
    """A rigid striker (m1 = 0.3 kg) given a velocity toward a free block
    (m2 = 0.6 kg, 0.1 mm away) and no contact key strikes it (issue 16:
    contact comes with the initial velocity).  A rigid mass on a free bar
    slows as v0 exp(−ρ c A t/m1) until the wave returns at 2L/c, so it keeps
    exp(−2 m2/m1) = 1.8 % of v0 (Johnson, Impact Strength of Materials,
    1972, §1.7); with a bar of four blocks, under 10 %.  Momentum: 1e-12."""
    h = run_case(STRIKE)
    m = h.static["particles/bodies/mass"]
    i = int(build_model(load_case_text(STRIKE)).groups["striker"][0])
    p = m * h.velocity[:, :, 0]
    assert np.all(np.abs(p.sum(axis=1) - 1.5) <= 1e-12 * 1.5)
    assert abs(h.velocity[-1, i, 0]) <= 0.1 * 5.0
    assert np.exp(-2 * 0.6 / 0.3) * 5.0 == pytest.approx(0.0916, abs=1e-4)


def test_too_stiff_contact_is_named_when_the_run_diverges(tmp_path, capsys):
    """stiffness: 100 makes the contact 100 × an internal face: the step
    taken from the springs is 7 × too large for it, the run diverges, and
    its message names the contact's stable step (exit 1, history kept)."""
    from rbsm_dyn.__main__ import main
    path = tmp_path / "stiff.yaml"
    path.write_text(textwrap.dedent(STRIKE) + "contact: {between: [striker, block], "
                    "stiffness: 100}\n")
    assert main([str(path), "--out", str(tmp_path / "stiff.h5"), "--quiet"]) == 1
    assert "contact stiffness lowers the stable step bound" in capsys.readouterr().err


def test_info_of_a_scene_held_by_contact_only(capsys):
    """Three free rigid blocks with contact and no springs: `info` gives
    the contact's stable step (finite) instead of failing on a zero
    stiffness matrix (ω_max = 0: no spring resists any motion)."""
    from rbsm_dyn.__main__ import main
    from rbsm_dyn.solvers.modal import omega_max
    text = textwrap.dedent("""
    name: info4
    parts:
      a: {geometry: {box: [[0, 0, 0], [0.1, 0.1, 0.1]]}, mesh: {kind: rigid}, material: stone}
      b: {geometry: {box: [[0.2, 0, 0], [0.3, 0.1, 0.1]]}, mesh: {kind: rigid}, material: stone}
      c: {geometry: {box: [[0.4, 0, 0], [0.5, 0.1, 0.1]]}, mesh: {kind: rigid}, material: stone}
    materials: {stone: {density: 2000, young: 5.0e9, poisson: 0.2}}
    contact: {between: all}
    solver: {mode: dynamic, end_time: 0.01}
    """)
    assert omega_max(build_model(load_case_text(text))) == 0.0
    import tempfile
    import os
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "info4.yaml")
        with open(path, "w") as f:
            f.write(text)
        assert main(["info", path]) == 0
    out = capsys.readouterr().out
    dt = float(out.split("stable dt")[1].split()[0])
    assert 0 < dt < 1.0


STACK = """
name: stack
parts:
  lower: {geometry: {box: [[0, 0, 0], [0.2, 0.2, 0.2]]}, mesh: {kind: rigid}, material: stone}
  upper: {geometry: {box: [[0, 0, 0.2], [0.2, 0.2, 0.4]]}, mesh: {kind: rigid}, material: stone}
materials: {stone: {density: 2000, young: 5.0e9, poisson: 0.2}}
loads: [{gravity: [0, 0, -9.81]}]
contact: {between: all, friction: 0.5, damping: 0.3, ground: {point: [0, 0, 0], normal: [0, 0, 1]}}
solver: {mode: dynamic, end_time: 0.1}
output: {interval: 0.01}
"""


def test_touching_rigid_parts_left_to_contact(run_case):
    """Two rigid blocks stacked face to face on the ground, no interface
    (two rigid parts cannot share springs): the contact key covers them,
    so they share no face and contact alone holds them.  They stay put:
    each centre within 10 × the static deflections of the two contacts
    (m g l/(E A) each, l = ½ V^⅓: 7.8e-8 m per block); the same scene
    without the contact key is refused, naming the two parts."""
    h = run_case(STACK)
    d = 2000 * 0.008 * 9.81 * 0.1 / (5.0e9 * 0.04)
    assert d == pytest.approx(7.848e-8, rel=1e-3)
    assert np.max(np.abs(h.position[:, 0, 2] - 0.1)) <= 10 * 2 * d
    assert np.max(np.abs(h.position[:, 1, 2] - 0.3)) <= 10 * 3 * d
    with pytest.raises(CaseError, match="parts lower and upper touch"):
        build_model(load_case_text("\n".join(
            line for line in STACK.splitlines() if not line.startswith("contact:"))))
