"""Contact between the cells of a plane model on the plane contact pass
(physics/plane_contact.py, issue 27 item 3): the overlap of two polygons
against the 3D overlap of their prisms, the pass against the slab's 3D
pass, and closed-form answers (two strips striking end on; a block sliding
to rest on a rough ground), momentum, threads and restart."""
import math

import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import apply_initial, build_model, new_state
from rbsm_dyn.physics.contact_geometry import overlap, overlap_halfspace
from rbsm_dyn.physics.plane_contact import (SCRATCH_ROWS_2D, overlap_2d,
                                            overlap_ground_2d)
from rbsm_dyn.physics.rotation import quat_matrix_np
from rbsm_dyn.solvers import explicit
from rbsm_dyn.solvers.plane import plane_contact_geometry

#: a Voronoi disc thrown at a rough ground: it shatters (rupture), its
#: fragments strike each other and the ground, slide and turn
DISC = """
name: disc-drop
plane: {kind: stress, thickness: 0.01}
domain: {circle: {center: [0.0, 0.06], radius: 0.05}}
mesh: {kind: voronoi, size: 0.005, seed: 3}
materials:
  c: {density: 2400, young: 30.0e9, poisson: 0.2,
      rupture: {tensile_strength: 3.0e6, fracture_energy: 20.0}}
initial: [{group: all, velocity: [3.0, -20.0]}]
contact: {between: all, friction: 0.5, damping: 0.1,
          ground: {point: [0, 0.0095], normal: [0, 1]}}
solver: {mode: dynamic, end_time: END}
output:
  interval: 2.0e-5
  checkpoint_interval: 1.0e-4
  fields: [position, orientation, velocity]
"""


def _disc(end="4.0e-4"):
    case = load_case_text(DISC.replace("END", end))
    return case, build_model(case)


def test_polygon_overlap_is_the_prisms_overlap():
    """overlap_2d of two cells' polygons, turned and moved at random into
    each other, times the thickness, is contact_geometry.overlap of their
    prisms: the volume, centroid and area vector S_B to 1e-9 (relative to
    the cell's size), over 400 placements, and likewise against the ground
    half-plane; at least a third of the placements do overlap."""
    _, model = _disc()
    cm = model.contact
    ptr, xy, edge_face, face_edge, radius, t = plane_contact_geometry(model)
    assert t == pytest.approx(0.01, rel=1e-12)
    n = model.n_bodies
    rot0 = quat_matrix_np(model.body_quat0[:n])
    rng = np.random.default_rng(27)
    w2 = np.zeros((SCRATCH_ROWS_2D(int(np.diff(ptr).max())), 3))
    w3 = np.zeros_like(cm_scratch(model))
    hits = 0
    for _ in range(400):
        a, b = rng.choice(n, 2, replace=False)
        th = rng.uniform(-math.pi, math.pi, 2)
        pos = np.zeros((n + 1, 2))
        d = rng.uniform(0.2, 1.0) * (radius[a] + radius[b])
        phi = rng.uniform(-math.pi, math.pi)
        pos[b] = pos[a] + d * np.array([math.cos(phi), math.sin(phi)])
        cs = np.zeros((n + 1, 2))
        cs[:, 0] = 1.0
        for c, x in ((a, th[0]), (b, th[1])):
            cs[c] = math.cos(x), math.sin(x)
        ar, c0, c1, s0, s1, sep = overlap_2d(a, b, pos, cs, ptr, xy, radius, face_edge,
                                             edge_face, -1, w2)

        def frame(c):
            rz = np.array([[cs[c, 0], -cs[c, 1], 0.0], [cs[c, 1], cs[c, 0], 0.0], [0, 0, 1.0]])
            return np.ascontiguousarray(rz @ rot0[c])

        pa, pb = np.r_[pos[a], 0.0], np.r_[pos[b], 0.0]
        v, q0, q1, q2, r0, r1, r2, area = overlap(a, pa, frame(a), b, pb, frame(b),
                                                  cm.cell_face_ptr, cm.loop_ptr, cm.loop_xyz,
                                                  cm.face_plane, cm.radius, w3)
        h = radius[a]
        assert t * ar == pytest.approx(v, abs=1e-9 * t * h * h)
        if v > 0:
            hits += 1
            assert sep == -1
            assert np.allclose([c0 + pos[a, 0], c1 + pos[a, 1], 0.0], [q0, q1, q2],
                               atol=1e-9 * h)
            assert np.allclose([t * s0, t * s1, 0.0], [r0, r1, r2], atol=1e-9 * t * h)
        # the ground line through b's centre with a random normal
        g = np.array([math.cos(phi), math.sin(phi)])
        gd = float(g @ pos[b])
        ag, d0, d1, e0, e1 = overlap_ground_2d(a, pos, cs, ptr, xy, radius, g[0], g[1], gd, w2)
        vg, *rest = overlap_halfspace(a, pa, frame(a), np.r_[g, 0.0], gd, cm.cell_face_ptr,
                                      cm.loop_ptr, cm.loop_xyz, cm.face_plane, cm.radius, w3)
        assert t * ag == pytest.approx(vg, abs=1e-9 * t * h * h)
        if vg > 0:
            assert np.allclose([d0 + pos[a, 0], d1 + pos[a, 1], 0.0], rest[:3], atol=1e-9 * h)
            assert np.allclose([t * e0, t * e1, 0.0], rest[3:6], atol=1e-9 * t * h)
    assert hits > 130


def cm_scratch(model):
    """One thread's 3D contact scratch of the model."""
    from rbsm_dyn.model.contact import new_contact_state
    return new_contact_state(model).scratch[0]


def _run(case, model, n_steps):
    state = new_state(model)
    state.dt = 0.8 * model.stable_dt()
    apply_initial(case, model, state)
    explicit.start_half_step(model, state)
    from rbsm_dyn.model.contact import chunk_steps, rebuild
    while state.step < n_steps:
        rebuild(model, state)
        k = min(n_steps - state.step, chunk_steps(model, state, state.dt, model.gravity))
        explicit.advance(model, state, k)
    return state


def test_plane_contact_pass_is_the_slab_pass(monkeypatch):
    """The disc thrown at the ground, 250 steps (it lands, cracks and its
    cells press on the ground and each other) on the plane passes and on
    its slab's 3D passes: the same springs broken, positions to 1e-9 of the
    largest displacement, the contact's friction work and slip to 1e-6."""
    import rbsm_dyn.solvers.explicit as ex
    case, model = _disc()
    a = _run(case, model, 250)
    monkeypatch.setattr(ex, "plane_ready", lambda *args: False)
    b = _run(case, model, 250)
    assert a.plane is not None and b.plane is None
    assert (b.contact.out[:, 8] > 0).sum() > 5          # cells pressed on the ground
    assert b.contact.body_friction.sum() > 0.0
    assert (b.spring_state >= 2).sum() > 20             # it cracked
    assert np.array_equal(a.spring_state, b.spring_state)
    scale = np.abs(b.body_pos - model.body_pos0).max()
    assert np.abs(a.body_pos - b.body_pos).max() <= 1e-9 * scale
    assert a.contact.body_friction.sum() == pytest.approx(b.contact.body_friction.sum(),
                                                          rel=1e-6)
    assert np.array_equal(a.contact.pairs, b.contact.pairs)
    assert np.allclose(a.contact.slip, b.contact.slip, atol=1e-6 * np.abs(b.contact.slip).max())


STRIKE = """
name: strips
plane: {kind: stress, thickness: 0.01}
parts:
  a: {geometry: {box: [[0, 0], [0.05, 0.01]]}, mesh: {kind: blocks, divisions: [25, 5]},
      material: steel}
  b: {geometry: {box: [[0.0501, 0], [0.1001, 0.01]]}, mesh: {kind: blocks, divisions: [25, 5]},
      material: steel}
materials:
  steel: {density: 7850, young: 200.0e9, poisson: 0.3}
initial: [{group: a, velocity: [10.0, 0]}]
contact: {between: [a, b], friction: 0.0}
solver: {mode: dynamic, end_time: 6.0e-5}
output:
  interval: 1.0e-6
  probes:
    va: {group: a, quantity: velocity, component: x, reduce: mean}
    vb: {group: b, quantity: velocity, component: x, reduce: mean}
"""


def test_strips_striking_end_on_swap_velocities(run_case):
    """Two equal elastic strips, one striking the other at 10 m/s (1D
    elastic impact, Goldsmith 1960 §2; Johnson, Impact Strength of
    Materials §3): the striker stops and the target leaves at 10 m/s
    (within 2 %), after a contact of 2L/c₀ (c₀ = √(E/ρ) in plane stress, to
    10 % — the penalty layer and the strips' lateral waves round the
    pulse), momentum kept to round-off and the energy balance closed."""
    h = run_case(STRIKE)
    va, vb = h.observables["va"], h.observables["vb"]
    assert abs(va[-1]) <= 0.2 and vb[-1] == pytest.approx(10.0, rel=0.02)
    assert np.allclose(va + vb, 10.0, rtol=1e-9)      # equal masses: m(va + vb) kept
    t = h.time
    # the strips' mean velocities change while they touch (the wave crosses
    # the target and back): from the first frame the target moves to the
    # first at its final velocity
    t0 = t[np.argmax(vb > 0.05)]
    t1 = t[np.argmax(np.abs(vb - vb[-1]) < 0.01)]
    c0 = math.sqrt(200.0e9 / 7850)
    assert t1 - t0 == pytest.approx(2 * 0.05 / c0, rel=0.10)
    eb = h.energy_balance()
    assert np.abs(eb["error"]).max() <= 0.01 * eb["supplied"][0]


SLIDE = """
name: slide
plane: {kind: stress, thickness: 0.01}
parts:
  block: {geometry: {box: [[0, 0], [0.1, 0.05]]}, mesh: {kind: rigid}, material: soft}
materials:
  soft: {density: 1000, young: 1.0e8, poisson: 0.2}
initial: [{group: block, velocity: [1.0, 0]}]
loads: [{gravity: [0, -9.81]}]
contact: {between: all, friction: 0.5, damping: 1.0, ground: {point: [0, 0], normal: [0, 1]}}
solver: {mode: dynamic, end_time: 0.3}
output:
  interval: 0.005
  probes:
    x: {group: block, quantity: displacement, component: x, reduce: mean}
    v: {group: block, quantity: velocity, component: x, reduce: mean}
"""


def test_block_slides_to_rest_by_coulomb_friction(run_case):
    """A block on a rough ground (μ = 0.5) given 1 m/s: Coulomb friction
    decelerates it at μg, so it stops after v₀/(μg) = 0.204 s having slid
    v₀²/(2μg) = 0.102 m (within 2 %), and the friction work equals its
    kinetic energy ½ m v₀² (within 2 %)."""
    h = run_case(SLIDE)
    x, v = h.observables["x"], h.observables["v"]
    g, mu = 9.81, 0.5
    assert x[-1] == pytest.approx(1.0 / (2 * mu * g), rel=0.02)
    t_stop = h.time[np.argmax(np.abs(v) < 1e-3)]
    assert t_stop == pytest.approx(1.0 / (mu * g), abs=0.01)
    m = 1000 * 0.1 * 0.05 * 0.01
    assert h.observables["contact_friction"][-1] == pytest.approx(0.5 * m, rel=0.02)


def test_plane_contact_threads_give_the_same_numbers(thread_states):
    """Each pair's force is its own and each body's sum in pair order: 1
    and 2 threads end the shattering disc in the same state bit for bit."""
    from rbsm_dyn.solvers.checkpoint import ARRAYS
    a, b = thread_states(DISC.replace("END", "2.0e-4"))
    assert np.abs(a["body_theta"]).max() > 1e-4
    for name in ARRAYS:
        assert np.array_equal(a[name], b[name]), name
    for name, v in a["contact"].items():
        assert np.array_equal(b["contact"][name], v), name


def test_plane_contact_restart_is_bitwise(tmp_path):
    """The disc's run continued from a mid-run checkpoint ends in the
    uninterrupted run's state and contact state bit for bit."""
    from rbsm_dyn.__main__ import main
    from rbsm_dyn.solvers.checkpoint import ARRAYS, read_checkpoint
    ref_case, case = tmp_path / "ref.yaml", tmp_path / "case.yaml"
    ref_case.write_text(DISC.replace("END", "3.0e-4"))
    case.write_text(DISC.replace("END", "1.5e-4"))
    ref, out = tmp_path / "ref.h5", tmp_path / "out.h5"
    assert main([str(ref_case), "--out", str(ref), "--quiet"]) == 0
    assert main([str(case), "--out", str(out), "--quiet"]) == 0
    case.write_text(DISC.replace("END", "3.0e-4"))
    assert main([str(case), "--restart", str(out), "--quiet"]) == 0
    got, _ = read_checkpoint(out)
    want, _ = read_checkpoint(ref)
    assert want["contact"]["builds"] >= 2
    for name in ARRAYS + ("step", "dt"):
        assert np.array_equal(got[name], want[name]), name
    for name, v in want["contact"].items():
        assert np.array_equal(got["contact"][name], v), name
