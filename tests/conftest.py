"""Shared helpers: run a case text through the command line in-process and
read its history.

The test models are small (10²–10⁴ springs): there a second Numba thread
costs more at each parallel region's barrier than it brings, so the suite
runs on one thread unless NUMBA_NUM_THREADS is set.  The parallel path is
tested on its own (test_dynamics.py: identical results with 1 and 2
threads, which sets NUMBA_NUM_THREADS=2 for its runs).

The suite runs in parallel workers (pytest-xdist, pyproject.toml addopts,
`--dist loadgroup`): each test goes to whichever worker is free, except
that the tests sharing a module-scoped fixture (a shipped case run once
for several tests) stay together in one worker, so that the fixture runs
once (pytest_collection_modifyitems below).

The model cache (io/model_cache.py) is off for the suite, so that running
the shipped cases writes nothing into cases/; test_model_cache.py turns it
on for its own runs."""
import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("RBSM_MODEL_CACHE", "0")

import textwrap  # noqa: E402

import pytest  # noqa: E402

import rbsm_dyn  # noqa: E402
from rbsm_dyn.__main__ import main  # noqa: E402


@pytest.fixture
def run_case(tmp_path):
    """run_case(yaml_text, *cli_args) -> History of the run (exit code 0 asserted)."""
    counter = iter(range(1000))

    def run(text, *args):
        k = next(counter)
        path = tmp_path / f"case{k}.yaml"
        path.write_text(textwrap.dedent(text), encoding="utf-8")
        out = tmp_path / f"run{k}.h5"
        code = main([str(path), "--out", str(out), "--quiet", *map(str, args)])
        assert code == 0
        return rbsm_dyn.open_history(out)

    return run


@pytest.fixture
def thread_states(tmp_path):
    """thread_states(yaml_text) -> the final checkpoint states of the case
    run in a subprocess with 1 and then 2 threads (NUMBA_NUM_THREADS=2)."""
    import subprocess
    import sys
    from rbsm_dyn.solvers.checkpoint import read_checkpoint

    def run(text):
        case = tmp_path / "threads.yaml"
        case.write_text(text)
        got = []
        for threads in (1, 2):
            out = tmp_path / f"t{threads}.h5"
            env = dict(os.environ, NUMBA_NUM_THREADS="2")
            r = subprocess.run([sys.executable, "-m", "rbsm_dyn", str(case), "--out", str(out),
                                "--quiet", "--threads", str(threads)], env=env,
                               capture_output=True, text=True, timeout=900)
            assert r.returncode == 0, r.stderr
            got.append(read_checkpoint(out)[0])
        return got

    return run


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Group the tests that share a module-scoped fixture (xdist_group), so
    that one worker runs them and builds the fixture once: within a module,
    the fixtures used together by a test join one group (connected
    components), so that a module's independent fixtures (test_case_answers'
    Brazilian disc and notched beam, each a full case run) can go to
    different workers.  tryfirst: pytest-xdist's own hook reads the marks
    into the node ids, and without it ran first and saw none (the fixtures
    were built on both workers, about 9 min of the suite's CPU)."""
    parent = {}

    def find(k):
        while parent.setdefault(k, k) != k:
            k = parent[k]
        return k

    shared_of = {}
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        if info is None:
            continue
        names = sorted(name for name, defs in info.name2fixturedefs.items()
                       if any(fd.scope in ("module", "package", "class") for fd in defs))
        if not names:
            continue
        keys = [(item.module.__name__, n) for n in names]
        for k in keys[1:]:
            parent[find(k)] = find(keys[0])
        shared_of[item] = keys[0]
    for item, key in shared_of.items():
        root = find(key)
        item.add_marker(pytest.mark.xdist_group(f"{root[0]}:{root[1]}"))
