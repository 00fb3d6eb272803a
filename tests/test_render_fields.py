"""Issue 17, items 4–6: the damage of the springs as a field (written,
exported, drawn), render's colourings (displacement components, damage),
the pre-cut notch apart from new cracks, the axes triad and scale bar in
every picture, the modal picture's frequency, and `plot` of a modal run
(frequencies, no energy balance).  Rendering is real (EGL on Mesa, as in
tests/test_render.py)."""
import textwrap

import numpy as np
import pytest
import pyvista as pv

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.io import render as render_mod
from rbsm_dyn.io.geometry import face_largest

from post_case import TINY, run_beam

#: a notched concrete bar pulled apart at 0.2 m/s (ramped over 50 µs):
#: its springs soften (damage between 0 and 1) over several frames before
#: the ligament breaks; 40 bodies, 280 springs, 42 frames, a few seconds
SOFT = textwrap.dedent("""\
    name: softening-bar
    description: notched concrete bar pulled apart, softening rupture
    domain: {box: [[0, 0, 0], [0.1, 0.01, 0.04]]}
    mesh: {kind: blocks, divisions: [10, 1, 4]}
    materials:
      concrete:
        density: 2400
        young: 30.0e9
        poisson: 0.0
        rupture: {fracture_energy: 100.0, tensile_strength: 3.0e6}
    groups:
      end: {box: [[0.09, -1, -1], [1, 1, 1]]}
    boundary:
      - {face: xmin, fix: all}
      - {group: end, velocity: [0.2, null, null], history: [[0, 0], [5.0e-5, 1], [1, 1]]}
    cuts:
      - {point: [0.05, 0, 0], normal: [1, 0, 0], within: [[0.045, -1, -1], [0.055, 1, 0.02]]}
    solver: {mode: dynamic, end_time: 8.0e-4}
    output:
      interval: 2.0e-5
      fields: [position, orientation, spring_state, spring_damage, cell_stress]
      probes:
        pull: {group: end, quantity: reaction, component: x, reduce: sum}
    """)

MODAL = textwrap.dedent("""\
    name: small-modes
    domain: {box: [[0, 0, 0], [0.4, 0.05, 0.1]]}
    mesh: {kind: blocks, divisions: [8, 1, 2]}
    materials:
      steel: {density: 8000, young: 200.0e9, poisson: 0.0}
    groups:
      tip: {box: [[0.35, -1, -1], [1, 1, 1]]}
    boundary: [{face: xmin, fix: all}]
    solver: {mode: modal, modes: 4}
    output:
      probes: {tip_z: {group: tip, quantity: displacement, component: z, reduce: mean}}
    """)


@pytest.fixture(scope="module")
def soft(tmp_path_factory):
    return run_beam(tmp_path_factory.mktemp("soft"), SOFT)


@pytest.fixture(scope="module")
def modal(tmp_path_factory):
    return run_beam(tmp_path_factory.mktemp("modal"), MODAL)


def read_png(path):
    img = pv.read(path)
    w, h, _ = img.dimensions
    return np.asarray(img.active_scalars)[:, :3].reshape(h, w, 3).astype(int)


def _softening_frame(h):
    """A frame where springs have softened (0 < D < 1) and none has broken
    since frame 0."""
    d, s = h.series["springs/damage"], h.spring_state
    for k in range(h.frames):
        if np.any((d[k] > 0) & (d[k] < 1)) and np.count_nonzero(s[k] >= 2) == \
                np.count_nonzero(s[0] >= 2):
            return k
    raise AssertionError("no frame with softening before the break")


# ------------------------------------------------------------- the field
def test_spring_damage_is_written_between_0_and_1_never_decreasing(soft):
    h = rbsm_dyn.open_history(soft)
    d, s = h.series["springs/damage"], h.spring_state
    assert d.dtype == np.float32 and d.shape == s.shape == (h.frames, h.n_springs)
    assert h.units["springs/damage"] == "1"
    assert d.min() >= 0.0 and d.max() <= 1.0
    assert np.all(np.diff(d, axis=0) >= 0)                  # damage is irreversible
    assert np.all(d[s >= 2] == 1.0)                         # broken: 1 (the notch too)
    notch = s[0] >= 2
    assert notch.any() and np.all(d[:, notch] == 1.0)
    # softening shows before the break: springs at 0 < D < 1 that break later
    soft_then_broken = np.any((d[:-1] > 0) & (d[:-1] < 1), axis=0) & (s[-1] >= 2) & ~notch
    assert soft_then_broken.sum() > 0
    assert np.count_nonzero(s[-1] >= 2) > np.count_nonzero(notch)    # a new crack
    assert np.all(d[(s < 2)] < 1.0)


def test_an_elastic_model_writes_zero_damage(run_case):
    text = TINY.replace("  probes:", "  fields: [position, spring_damage]\n  probes:")
    h = run_case(text)
    d = h.series["springs/damage"]
    assert d.shape == (h.frames, h.n_springs) and not d.any()


# ----------------------------------------------------------------- export
def test_export_writes_the_damage_of_faces_and_cells(soft, tmp_path):
    from rbsm_dyn.io.export import export
    h = rbsm_dyn.open_history(soft)
    k = _softening_frame(h)
    res = export(soft, tmp_path / "vtk", frames=[k, h.frames - 1])
    assert res["face_files"] == 2
    faces = pv.read(tmp_path / "vtk" / "faces" / f"frame_{k:06d}.vtp")
    cells = pv.read(tmp_path / "vtk" / "cells" / f"frame_{k:06d}.vtu")
    geom = h.geometry()
    fdmg, bdmg = face_largest(h.series["springs/damage"][k], h.static["springs/face"],
                              geom.n_faces, geom.n_bfaces)
    fid = np.asarray(faces.cell_data["face_id"])
    dm = np.asarray(faces.cell_data["damage"])
    expect = np.where(fid >= 0, fdmg[np.maximum(fid, 0)], bdmg[np.maximum(-1 - fid, 0)])
    assert dm == pytest.approx(expect)
    # softening faces are in the file though elastic by state, and every
    # damaged face is there
    state = np.asarray(faces.cell_data["state"])
    assert np.any((state == 0) & (dm > 0) & (dm < 1))
    assert set(fid[fid >= 0]) >= set(np.nonzero(fdmg > 0)[0])
    assert np.all(dm[state >= 2] == 1.0)
    cd = np.asarray(cells.cell_data["damage"])
    assert cd.shape == (h.n_bodies,) and 0 < cd.max() <= 1


# ----------------------------------------------------------------- render
def test_render_color_damage_colours_softening_faces(soft, tmp_path):
    h = rbsm_dyn.open_history(soft)
    k = _softening_frame(h)
    a = render_mod.render(soft, frame=k, out=tmp_path / "u.png", window_size=(600, 300))
    assert main(["render", str(soft), "--frame", str(k), "--color", "damage",
                 "--out", str(tmp_path / "d.png"), "--size", "600", "300", "--quiet"]) == 0
    b = render_mod.render(soft, frame=k, out=tmp_path / "d2.png", window_size=(600, 300),
                          color="damage")
    assert b["n_damaged_faces"] > 0 and b["color_range"] == (0.0, 1.0)
    assert a["n_damaged_faces"] == 0
    pa, pb = read_png(a["out"]), read_png(tmp_path / "d.png")
    assert pa.shape == pb.shape
    differ = np.any(np.abs(pa - pb) > 30, axis=-1)
    assert differ.mean() > 0.05                      # grey cells, not viridis
    # the softening faces drawn in the damage colours (yellow to red: R high, B low)
    warm = (pb[..., 0] > 200) & (pb[..., 2] < 120) & (pb[..., 0] - pb[..., 2] > 100)
    assert warm.sum() > 20


def test_render_damage_without_the_field_says_which_to_ask_for(tmp_path, capsys):
    beam = run_beam(tmp_path)
    assert main(["render", str(beam), "--color", "damage",
                 "--out", str(tmp_path / "x.png")]) == 2
    assert "spring_damage" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("color", ["ux", "uy", "uz", "von_mises", "sxx"])
def test_render_colours_by_a_displacement_component_or_stress(soft, tmp_path, color):
    res = render_mod.render(soft, out=tmp_path / f"{color}.png", window_size=(300, 150),
                            color=color)
    lo, hi = res["color_range"]
    if color != "von_mises":
        assert lo == -hi and hi > 0                   # signed, symmetric about 0
    h = rbsm_dyn.open_history(soft, frames=-1)
    if color == "ux":
        assert hi == pytest.approx(np.abs(h.displacement[0][:, 0]).max(), rel=0.5)
    assert (tmp_path / f"{color}.png").stat().st_size > 0


def test_the_notch_is_drawn_apart_from_new_cracks(soft, tmp_path, monkeypatch):
    h = rbsm_dyn.open_history(soft)
    res = render_mod.render(soft, out=tmp_path / "last.png", window_size=(800, 400))
    cut = np.unique(h.static["springs/face"][h.spring_state[0] >= 2])
    assert res["n_notch_faces"] == len(cut) > 0
    assert res["n_new_crack_faces"] > 0
    assert res["n_broken_faces"] == res["n_notch_faces"] + res["n_new_crack_faces"]
    assert render_mod.NOTCH_COLOR != render_mod.CRACK_COLOR
    first = render_mod.render(soft, frame=0, out=tmp_path / "first.png", window_size=(800, 400))
    assert first["n_notch_faces"] == len(cut) and first["n_new_crack_faces"] == 0
    # the notch in its own colour (made green here to find it), new cracks red
    monkeypatch.setattr(render_mod, "NOTCH_COLOR", "lime")
    render_mod.render(soft, out=tmp_path / "lime.png", window_size=(800, 400))
    rgb = read_png(tmp_path / "lime.png")
    red = (rgb[..., 0] > 200) & (rgb[..., 1] < 60) & (rgb[..., 2] < 60)
    lime = (rgb[..., 1] > 200) & (rgb[..., 0] < 60) & (rgb[..., 2] < 60)
    assert red.sum() > 20 and lime.sum() > 20
    rgb0 = read_png(tmp_path / "first.png")
    red0 = (rgb0[..., 0] > 200) & (rgb0[..., 1] < 60) & (rgb0[..., 2] < 60)
    assert red0.sum() == 0                          # frame 0: only the notch, not red


def test_every_picture_has_axes_and_a_scale_bar(soft):
    pl, info = render_mod.build_plotter(soft, window_size=(400, 200))
    try:
        assert pl.renderer.axes_actor is not None
        assert pl.renderer.axes_widget is not None and pl.renderer.axes_widget.GetEnabled()
        assert "scale_bar" in pl.actors and "scale_bar_label" in pl.actors
        L, label = info["scale_bar"]
        assert L == render_mod.nice_length(L) and label == render_mod.format_length(L)
        assert 0.1 * 0.1 <= L <= 0.1                   # a share of the 0.1 m bar
    finally:
        pl.close()


@pytest.mark.parametrize("x, expect", [(0.037, 0.02), (0.05, 0.05), (0.99, 0.5), (7.0, 5.0),
                                       (1.0e-4, 1.0e-4), (2.4e-6, 2.0e-6)])
def test_nice_length_is_1_2_or_5_times_a_power_of_10(x, expect):
    assert render_mod.nice_length(x) == pytest.approx(expect)


@pytest.mark.parametrize("L, text", [(0.02, "20 mm"), (0.5, "500 mm"), (1.0, "1 m"),
                                     (2.0e-6, "2 um"), (5.0e-3, "5 mm"), (2000.0, "2 km")])
def test_scale_bar_labels(L, text):
    assert render_mod.format_length(L) == text


# ------------------------------------------------------------------ modal
def test_render_of_a_mode_names_its_frequency(modal, tmp_path, capsys):
    h = rbsm_dyn.open_history(modal)
    f = np.asarray(h.static["modes/frequency"])
    res = render_mod.render(modal, frame=2, out=tmp_path / "m2.png", window_size=(400, 200))
    assert res["title"] == f"mode 2, f = {f[1]:.4g} Hz"
    assert main(["render", str(modal), "--frame", "1", "--out", str(tmp_path / "m1.png"),
                 "--size", "400", "200"]) == 0
    assert f"mode 1, f = {f[0]:.4g} Hz" in capsys.readouterr().out


def test_plot_of_a_modal_history_draws_frequencies_not_an_energy_balance(
        modal, tmp_path, monkeypatch, capsys):
    import matplotlib.figure
    figs = []
    save = matplotlib.figure.Figure.savefig

    def keep(fig, *a, **k):
        figs.append(fig)
        return save(fig, *a, **k)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    res = render_mod.plot(modal, out=tmp_path / "p.png")
    h = rbsm_dyn.open_history(modal)
    f = np.asarray(h.static["modes/frequency"])
    assert res["balance_error"] is None and res["mode"] == "modal"
    assert res["frequencies"] == pytest.approx(f) and res["probes"] == ["tip_z"]
    (fig,) = figs
    labels = [ln.get_label() for ax in fig.axes for ln in ax.get_lines()]
    assert not any("balance" in lb or "strain" in lb or "kinetic" in lb for lb in labels)
    heights = sorted(p.get_height() for p in fig.axes[0].patches)
    assert heights == pytest.approx(sorted(f))
    assert fig.axes[0].get_ylabel() == "natural frequency [Hz]"
    assert main(["plot", str(modal), "--out", str(tmp_path / "q.png")]) == 0
    out = capsys.readouterr().out
    assert "4 natural frequencies" in out and "balance" not in out


def test_plot_of_a_dynamic_history_still_draws_the_balance(soft, tmp_path, monkeypatch):
    import matplotlib.figure
    figs = []
    save = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig",
                        lambda fig, *a, **k: (figs.append(fig), save(fig, *a, **k))[1])
    res = render_mod.plot(soft, out=tmp_path / "p.png")
    assert res["mode"] == "dynamic" and 0 <= res["balance_error"] < 0.05
    labels = [ln.get_label() for ln in figs[0].axes[0].get_lines()]
    assert "balance error" in labels and "fracture" in labels


# ------------------------------------------------------------------- help
@pytest.mark.parametrize("command, text", [("render", render_mod.RENDER_DESCRIPTION),
                                           ("plot", render_mod.PLOT_DESCRIPTION)])
def test_help_descriptions_are_whole_sentences(command, text, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert " ".join(text.split()) in out and text.rstrip().endswith(".")


def test_on_a_tie_the_view_looks_across_the_displacements():
    """A square cantilever (1 × 0.1 × 0.1) bending sideways (y) is seen from
    above (along z), not end-on; bending in z, from the side (along y)."""
    lo, hi = [0, 0, 0], [1.0, 0.1, 0.1]
    sideways = np.array([[0, 1e-3, 0], [0, 2e-3, 0]])
    direction, up = render_mod._view(lo, hi, sideways)
    assert abs(direction[2]) == 1 and up[1] == 1
    direction, up = render_mod._view(lo, hi, sideways[:, [0, 2, 1]])
    assert abs(direction[1]) == 1 and up[2] == 1
    direction, _ = render_mod._view(lo, hi)                  # no displacements: y first
    assert abs(direction[1]) == 1
    direction, _ = render_mod._view(lo, [1.0, 0.1, 0.2], sideways)   # no tie: thinnest
    assert abs(direction[1]) == 1


def test_the_view_is_isometric_for_a_solid_and_along_the_thin_side_for_a_plane_model():
    """--view auto: a cube of 10 × 10 × 10 cells is seen isometrically (a
    slab's cracked underside is no longer hidden by a view from the top);
    a slab one cell thick in y (a plane model) along y; -z from below."""
    iso, up = render_mod._view([0, 0, 0], [1, 1, 1], None, "auto", cell_size=0.1)
    assert np.allclose(iso, np.array([1, -1, 1]) / np.sqrt(3)) and up[2] == 1
    side, up = render_mod._view([0, 0, 0], [1, 0.05, 1], None, "auto", cell_size=0.05)
    assert abs(side[1]) == 1 and up[2] == 1
    below, up = render_mod._view([0, 0, 0], [1, 1, 0.2], None, "-z", cell_size=0.05)
    assert below[2] == -1 and up[1] == 1
    with pytest.raises(ValueError, match="--view"):
        render_mod._view([0, 0, 0], [1, 1, 1], None, "top")
