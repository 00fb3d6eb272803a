"""What is made from a history lands by default in one folder beside it,
RUN/ for RUN.h5 (issue 17 item 10): export's vtk/, render's frameK.png,
plot's plot.png; the working directory keeps one file and one folder per
run."""
import shutil

from rbsm_dyn.__main__ import main

from post_case import run_beam


def test_export_render_and_plot_default_to_the_run_folder(tmp_path):
    (tmp_path / "make").mkdir()
    src = run_beam(tmp_path / "make")
    run = tmp_path / "work" / "beam.h5"
    run.parent.mkdir()
    shutil.copy(src, run)
    assert main(["export", str(run), "--every", "1000", "--quiet"]) == 0
    assert main(["render", str(run), "--size", "200", "100", "--quiet"]) == 0
    assert main(["plot", str(run), "--quiet"]) == 0
    folder = tmp_path / "work" / "beam"
    assert (folder / "vtk" / "cells.pvd").is_file()
    assert any(p.name.startswith("frame") and p.suffix == ".png" for p in folder.iterdir())
    assert (folder / "plot.png").is_file()
    # nothing else beside the history
    assert sorted(p.name for p in run.parent.iterdir()) == ["beam", "beam.h5"]
