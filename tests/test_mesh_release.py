"""A run steps without the mesh's arrays (issue 29 item 8): once the
Recorder has written the geometry to the history, cli/run.py replaces the
model's Mesh by a MeshSummary (Model.without_mesh_arrays) and nothing holds
the Mesh any more; the history is the same to the bit, the model cache
keeps the whole mesh, and Newton, linear and modal runs keep it."""
import gc
import pickle
import weakref
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from rbsm_dyn.__main__ import main
from rbsm_dyn.case import load_case, load_case_text
from rbsm_dyn.cli import prepare, run as cli_run
from rbsm_dyn.io import model_cache
from rbsm_dyn.mesh._core import Mesh
from rbsm_dyn.model import MeshSummary, build_model
from rbsm_dyn.solvers import explicit, relax

# a Voronoi beam on a rigid block with contact and a surface probe, a
# point probe and cell stress under a surface load: every reader of the
# mesh that a run has (contact build, probe plan, surface levers, geometry)
CASE = """\
name: release
units: SI
parts:
  beam:
    geometry: {box: [[0, 0, 0.05], [0.4, 0.05, 0.1]]}
    mesh: {kind: voronoi, size: 0.025, seed: 3}
    material: concrete
  block:
    geometry: {box: [[0, 0, 0], [0.05, 0.05, 0.05]]}
    mesh: {kind: rigid}
    material: steel
interfaces: [{parts: [beam, block], law: bonded}]
contact: {between: all}
materials:
  concrete: {density: 2400, young: 3.0e10, poisson: 0.3}
  steel: {density: 7850, young: 2.0e11, poisson: 0.3}
boundary: [{group: block, fix: all}]
loads: [{surface: beam.xmax, traction: [0, 0, -1.0e5]}]
solver: {mode: dynamic, end_time: 4.0e-5}
output:
  interval: 1.0e-5
  fields: [position, orientation, velocity, spring_force, cell_stress]
  probes:
    tip: {quantity: displacement, surface: beam.xmax, component: z, reduce: mean}
    gap: {quantity: relative_displacement, points: [[0.1, 0.025, 0.075], [0.3, 0.025, 0.075]], component: z}
"""


def _other_mode(solver):
    """CASE in another solver mode (no contact, no output interval)."""
    return (CASE.replace("contact: {between: all}\n", "").replace("  interval: 1.0e-5\n", "")
            .replace("solver: {mode: dynamic, end_time: 4.0e-5}", f"solver: {solver}"))


@pytest.fixture
def case_file(tmp_path):
    path = tmp_path / "release.yaml"
    path.write_text(CASE)
    return path


def _watch(monkeypatch, solver_module):
    """Record, when the solver starts, the model it steps and whether the
    build's Mesh is still alive."""
    seen = {}
    model_of = prepare._model

    def built(*a, **kw):
        model = model_of(*a, **kw)
        seen["mesh"] = weakref.ref(model.mesh)
        return model

    inner = solver_module.run

    def stepping(case, model, rec, **kw):
        gc.collect()
        seen["model"], seen["rec_model"] = model, rec.model
        seen["alive"] = seen["mesh"]() is not None
        return inner(case, model, rec, **kw)

    monkeypatch.setattr(prepare, "_model", built)
    monkeypatch.setattr(solver_module, "run", stepping)
    return seen


def test_a_dynamic_run_steps_without_the_mesh_and_writes_the_same_history(case_file,
                                                                          monkeypatch):
    out = [case_file.parent / f"run{k}.h5" for k in range(2)]
    seen = _watch(monkeypatch, explicit)
    assert main([str(case_file), "--out", str(out[0]), "--quiet"]) == 0
    assert isinstance(seen["model"].mesh, MeshSummary)
    assert seen["rec_model"] is seen["model"]
    assert seen["model"].contact is not None
    assert not seen["alive"], "something still holds the build's Mesh while the run steps"
    # the same run keeping the mesh: the same history, to the bit
    monkeypatch.setattr(cli_run, "_release_mesh", lambda case: False)
    assert main([str(case_file), "--out", str(out[1]), "--quiet"]) == 0
    assert isinstance(seen["model"].mesh, Mesh) and seen["alive"]
    with h5py.File(out[0]) as a, h5py.File(out[1]) as b:
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert "particles/bodies/stress/value" in names and "observables/gap/value" in names
        for name in names:
            if name.startswith("parameters"):
                continue
            x, y = a[name][()], b[name][()]
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True), name


def test_a_relaxation_run_steps_without_the_mesh(tmp_path, monkeypatch):
    path = tmp_path / "relax.yaml"
    path.write_text(_other_mode("{mode: static, method: relaxation, load_steps: 2, "
                                "tolerance: 1.0e-2}"))
    seen = _watch(monkeypatch, relax)
    assert main([str(path), "--out", str(tmp_path / "r.h5"), "--quiet"]) == 0
    assert isinstance(seen["model"].mesh, MeshSummary) and not seen["alive"]


def test_newton_linear_and_modal_keep_the_mesh():
    for solver in ("{mode: static, method: newton}", "{mode: linear}",
                   "{mode: modal, modes: 3}"):
        case = load_case_text(_other_mode(solver), "x.yaml")
        assert not cli_run._release_mesh(case), solver
    creep = SimpleNamespace(solver=SimpleNamespace(mode="static", method="relaxation",
                                                   time=[1.0, 2.0]))
    assert not cli_run._release_mesh(creep)


def test_the_summary_keeps_the_bounds_and_names_and_refuses_the_arrays():
    case = load_case_text(CASE, "release.yaml")
    model = build_model(case)
    light = model.without_mesh_arrays()
    assert light is not model and model.mesh is not light.mesh
    assert isinstance(model.mesh, Mesh)                    # (the model is not changed)
    assert light.without_mesh_arrays() is light
    s = light.mesh
    assert s.n_cells == model.n_bodies == model.mesh.n_cells
    assert np.array_equal(s.box, model.mesh.box)
    assert s.surface_names == tuple(model.mesh.surface_names)
    assert s.part_names == ("beam", "block")
    with pytest.raises(AttributeError, match="released"):
        s.vertices
    assert getattr(s, "bface_cell", None) is None
    pickle.loads(pickle.dumps(light))
    # every other field is the model's own array, not a copy
    for name in ("body_mass", "spring_bodies", "face_k", "contact", "groups"):
        assert getattr(light, name) is getattr(model, name)


def test_the_model_cache_keeps_the_whole_mesh(case_file, monkeypatch):
    monkeypatch.setenv("RBSM_MODEL_CACHE", "1")
    monkeypatch.setattr(model_cache, "MIN_BUILD_SECONDS", 0.0)
    assert main([str(case_file), "--out", str(case_file.parent / "c.h5"), "--quiet"]) == 0
    cached = model_cache.load(load_case(case_file))
    assert cached is not None and isinstance(cached.mesh, Mesh)
    assert len(cached.mesh.vertices) > 0
