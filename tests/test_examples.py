"""examples/ run as tests (scikit-fem style): the quickstart script runs
its small case, reads the history, plots a probe and the energy balance and
draws the crack; its notebook is the same code (examples/sync_notebook.py)."""
import json
import runpy
import sys
from pathlib import Path


EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def test_quickstart_notebook_is_the_script():
    sys.path.insert(0, str(EXAMPLES))
    try:
        import sync_notebook
    finally:
        sys.path.remove(str(EXAMPLES))
    script = (EXAMPLES / "quickstart.py").read_text(encoding="utf-8")
    committed = (EXAMPLES / "quickstart.ipynb").read_text(encoding="utf-8")
    assert committed == sync_notebook.notebook_text(script), \
        "examples/quickstart.ipynb is stale: run python examples/sync_notebook.py"
    nb = json.loads(committed)
    kinds = [c["cell_type"] for c in nb["cells"]]
    assert kinds.count("code") == 5 and kinds.count("markdown") == 5


def test_quickstart_runs_and_finds_a_crack_across_the_plate(tmp_path, monkeypatch):
    """The notch ends at x = 6 mm; under 15 MPa the crack runs on to the far
    side (x = 30 mm) within 30 µs, and the energy balance holds to 2 %."""
    import matplotlib.pyplot as plt
    monkeypatch.setenv("RBSM_EXAMPLE_OUT", str(tmp_path))
    try:
        ns = runpy.run_path(str(EXAMPLES / "quickstart.py"), run_name="__main__")
    finally:
        plt.close("all")
    h = ns["h"]
    assert h.status == "completed" and h.frames == 66
    assert ns["n_broken_faces"] > 20
    assert ns["crack_tip_x"] > 0.025
    assert ns["balance_error"] < 0.02
    for name in ("probe_energy.png", "cracks.png", "quickstart.h5"):
        assert (tmp_path / name).stat().st_size > 10_000, name
