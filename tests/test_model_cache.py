"""The model cache beside a case (io/model_cache.py, issue 15 item 3): a
rerun reads the model a first run built, the same to the bit; anything a
build reads changes the key; a damaged or foreign file is a rebuild."""
import dataclasses
import json
import textwrap

import h5py
import numpy as np
import pytest

from rbsm_dyn.__main__ import main
from rbsm_dyn.case import load_case, load_case_text
from rbsm_dyn.io import model_cache
from rbsm_dyn.model import build_model

# two parts (a Voronoi beam on a rigid block, bonded), a support on a
# named surface, a load: the model holds groups, a mesh, the Poisson and
# law tables, interfaces
CASE = """\
name: cached
units: SI
parts:
  beam:
    geometry: {box: [[0, 0, 0.05], [0.4, 0.05, 0.1]]}
    mesh: {kind: voronoi, size: 0.02, seed: 3}
    material: concrete
  block:
    geometry: {box: [[0, 0, 0], [0.05, 0.05, 0.05]]}
    mesh: {kind: rigid}
    material: steel
interfaces: [{parts: [beam, block], law: bonded}]
materials:
  concrete: {density: 2400, young: 3.0e10, poisson: 0.3}
  steel: {density: 7850, young: 2.0e11, poisson: 0.3}
boundary: [{group: block, fix: all}]
loads: [{surface: beam.xmax, traction: [0, 0, -1.0e5]}]
solver: {mode: dynamic, end_time: 2.0e-5}
output: {interval: 1.0e-5}
"""


def same(a, b, path="model"):
    """Every array, scalar and class of two models equal, to the bit."""
    if isinstance(a, np.ndarray):
        assert type(b) is np.ndarray and a.dtype == b.dtype and a.shape == b.shape, path
        assert np.array_equal(a, b, equal_nan=True), path
    elif dataclasses.is_dataclass(a):
        assert type(a) is type(b), path
        for f in dataclasses.fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, (list, tuple)):
        assert type(a) is type(b) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(a, dict):
        assert list(a) == list(b), path
        for k in a:
            same(a[k], b[k], f"{path}[{k}]")
    else:
        assert type(a) is type(b) and (a == b or (a != a and b != b)), (path, a, b)


@pytest.fixture
def case_file(tmp_path):
    path = tmp_path / "beam.yaml"
    path.write_text(CASE)
    return path


def test_a_cached_model_is_the_built_model(case_file):
    case = load_case(case_file)
    model = build_model(case)
    path = model_cache.save(case, model)
    assert path == case_file.parent / ".rbsm_cache" / "beam.yaml.model.npz"
    same(model, model_cache.load(case))


def test_the_key_follows_what_a_build_reads(case_file, tmp_path):
    key = model_cache.cache_key(load_case(case_file))

    def key_of(old, new):
        p = tmp_path / "other.yaml"
        p.write_text(CASE.replace(old, new))
        return model_cache.cache_key(load_case(p))

    # read by no build: output, name, initial, thread count
    assert key_of("interval: 1.0e-5", "interval: 5.0e-6") == key
    assert key_of("name: cached", "name: renamed") == key
    assert key_of("solver: {mode: dynamic,", "solver: {threads: 2, mode: dynamic,") == key
    assert key_of("output:", "initial: [{velocity: [1, 0, 0]}]\noutput:") == key
    # read by a build: mesh, materials, geometry, supports, loads, solver
    for old, new in [("seed: 3", "seed: 4"), ("young: 3.0e10", "young: 3.1e10"),
                     ("0.4, 0.05", "0.41, 0.05"), ("beam.xmax", "beam.ymax"),
                     ("-1.0e5", "-2.0e5"), ("end_time: 2.0e-5", "end_time: 3.0e-5")]:
        assert key_of(old, new) != key, (old, new)
    # the same numbers in other units are another model (lengths in mm)
    mm = CASE.replace("units: SI", "units: mm-N-s")
    assert model_cache.cache_key(load_case_text(mm, str(tmp_path / "mm.yaml"))) != key


def test_a_geometry_file_enters_the_key(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    stl = tmp_path / "block.stl"
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(stl)
    path = tmp_path / "file.yaml"
    path.write_text(textwrap.dedent("""\
        name: f
        domain: {file: block.stl}
        mesh: {kind: voronoi, size: 0.03, seed: 1}
        materials: {m: {density: 2400, young: 3.0e10, poisson: 0.2}}
        boundary: [{surface: file0.surface, fix: all}]
        solver: {mode: dynamic, end_time: 1.0e-5}
        """))
    key = model_cache.cache_key(load_case(path))
    trimesh.creation.box(extents=[0.1, 0.1, 0.12]).export(stl)
    assert model_cache.cache_key(load_case(path)) != key


def test_a_rerun_reads_the_model_and_gives_the_same_history(case_file, monkeypatch, capsys):
    monkeypatch.setenv("RBSM_MODEL_CACHE", "1")
    monkeypatch.setattr(model_cache, "MIN_BUILD_SECONDS", 0.0)
    out = [case_file.parent / f"run{k}.h5" for k in range(3)]
    assert main([str(case_file), "--out", str(out[0])]) == 0
    assert "model cached in" in capsys.readouterr().err
    assert main([str(case_file), "--out", str(out[1])]) == 0
    assert "model read from" in capsys.readouterr().err
    assert main([str(case_file), "--out", str(out[2]), "--no-model-cache"]) == 0
    assert "model read from" not in capsys.readouterr().err
    with h5py.File(out[0]) as a, h5py.File(out[1]) as b, h5py.File(out[2]) as c:
        for name in ("particles/bodies/position/value", "observables/kinetic/value"):
            assert np.array_equal(a[name][()], b[name][()]), name
            assert np.array_equal(a[name][()], c[name][()]), name


def test_a_damaged_or_foreign_file_is_a_rebuild(case_file):
    case = load_case(case_file)
    path = model_cache.save(case, build_model(case))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])            # cut short
    assert model_cache.load(case) is None
    # a tree naming a class outside the package is refused, not imported
    head = {"format": 1, "key": model_cache.cache_key(case),
            "tree": {"dc": "os:system", "f": {}}}
    np.savez(path, __head__=np.frombuffer(json.dumps(head).encode(), dtype=np.uint8))
    assert model_cache.load(case) is None


def test_an_unwritable_folder_is_a_note_not_an_error(case_file):
    case = load_case(case_file)
    (case_file.parent / ".rbsm_cache").write_text("a file where the folder would be")
    notes = []
    assert model_cache.save(case, build_model(case), notes.append) is None
    assert "cannot write" in notes[0]
