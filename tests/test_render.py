"""`python -m rbsm_dyn render RUN.h5` draws the deformed cells off-screen
with the magnification written in the picture and the cracks in red;
`plot` draws energies and probes (rbsm_dyn/io/render.py).  Rendering here
is real: VTK's EGL window on Mesa (no screen, no Xvfb)."""
import numpy as np
import pytest
import pyvista as pv

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.io import render as render_mod

from post_case import run_beam


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    return run_beam(tmp_path_factory.mktemp("render"))


def read_png(path):
    img = pv.read(path)
    w, h, _ = img.dimensions
    rgb = np.asarray(img.active_scalars)[:, :3].reshape(h, w, 3).astype(int)
    return w, h, rgb


def test_render_draws_the_deformed_cells_cut_apart_from_cracks(beam, tmp_path, capsys):
    png = tmp_path / "beam.png"
    assert main(["render", str(beam), "--out", str(png), "--scale", "5",
                 "--size", "800", "400"]) == 0
    out = capsys.readouterr().out
    assert "magnified x 5" in out and "broken" in out
    w, h, rgb = read_png(png)
    assert (w, h) == (800, 400)
    white = np.all(rgb > 245, axis=-1)
    assert 0.05 < 1 - white.mean() < 0.9                 # something drawn, not all
    red = (rgb[..., 0] > 200) & (rgb[..., 1] < 60) & (rgb[..., 2] < 60)
    orange = (rgb[..., 0] > 220) & (rgb[..., 1] > 120) & (rgb[..., 1] < 190) & (rgb[..., 2] < 60)
    assert red.sum() == 0     # no crack forms in this run; the cut is drawn black (render.NOTCH_COLOR)
    assert orange.sum() > 20                             # yielded faces at the clamp


def test_render_result_states_the_factor_and_counts(beam, tmp_path):
    res = render_mod.render(beam, frame=0, out=tmp_path / "f0.png", window_size=(400, 200))
    assert res["frame"] == 0 and res["time"] == 0.0
    assert res["scale"] == 1.0 and res["max_displacement"] < 1e-12   # nothing moved yet
    h = rbsm_dyn.open_history(beam, frames=0)
    cut = np.unique(h.static["springs/face"][h.spring_state[0] >= 2])
    assert res["n_broken_faces"] == len(cut) == 2      # the cut: 7 spring points on 2 faces
    assert res["renderer"] in ("egl", "osmesa", "x") or res["renderer"].startswith("vtk")


@pytest.mark.parametrize("max_disp, size, expect", [
    (1.28e-4, 0.085, 20.0),     # the dynamic-crack picture: 0.04·0.085/1.28e-4 = 26.6 -> 20
    (2.4e-2, 0.2, 1.0),         # large enough already: never shrink
    (1e-6, 1.0, 20000.0),       # 4e4 -> 2e4
    (3e-3, 0.2, 2.0),           # 2.67 -> 2
    (0.0, 0.2, 1.0),
    (1e-17, 0.2, 1.0),          # round-off, not a displacement
])
def test_auto_scale_rounds_down_to_1_2_5(max_disp, size, expect):
    assert render_mod.auto_scale(max_disp, size) == expect


def test_without_any_opengl_the_error_says_what_to_install(beam, tmp_path, capsys, monkeypatch):
    for var in ("DISPLAY", "WAYLAND_DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(render_mod.ctypes.util, "find_library", lambda name: None)
    assert main(["render", str(beam), "--out", str(tmp_path / "x.png")]) == 1
    err = capsys.readouterr().err
    assert "libegl-mesa0" in err and "libosmesa6" in err and "xvfb-run" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()


def test_plot_draws_energies_and_probes(beam, tmp_path, capsys):
    png = tmp_path / "plot.png"
    assert main(["plot", str(beam), "--out", str(png)]) == 0
    out = capsys.readouterr().out
    assert "1 probes" in out and "energy balance error" in out
    w, h, rgb = read_png(png)
    assert w == 800 and h > 400
    assert 0.02 < 1 - np.all(rgb > 245, axis=-1).mean() < 0.6


def test_a_colour_the_history_cannot_give_is_named_without_quotes(beam, tmp_path, capsys):
    """--color von_mises on a history written without cell_stress: exit 2
    and one line saying which field to add, not a Python KeyError's repr."""
    assert main(["render", str(beam), "--color", "von_mises",
                 "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "add cell_stress" in err, err
    assert err.startswith("rbsm_dyn: render: ") and "'" not in err and '"' not in err, err


def test_plot_names_the_plastic_work_for_what_the_case_dissipates():
    """`plastic` holds yield and crack friction (solvers/output.py): a case
    without yield is labelled friction, one with yield says both."""
    brittle = {"materials": {"g": {"young": 6e10, "yield": None, "rupture": {"strain": 1e-3}}}}
    ductile = {"materials": {"s": {"young": 2e11, "yield": {"criterion": "tresca"}}}}
    assert render_mod._plastic_label(brittle) == "friction on closed cracks"
    assert "yield" in render_mod._plastic_label(ductile)
    assert render_mod.PANEL_LABELS["n_broken"] == "broken spring points"
