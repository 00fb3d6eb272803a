"""python -m rbsm_dyn sweep (issue 29 item 6): an ensemble over mesh seeds
and key values, run side by side, its probes' scatter tabulated."""
import csv
import subprocess
import sys

import numpy as np

import rbsm_dyn

BAR = """\
# a Voronoi cantilever under a tip load, linear
name: bar
domain: {box: [[0, 0, 0], [0.2, 0.02, 0.02]]}
mesh: {kind: voronoi, size: 0.01, seed: 1}
materials:
  c: {density: 2400, young: 30.0e9, poisson: 0.2}
groups:
  tip: {box: [[0.19, -1, -1], [1, 1, 1]]}
boundary:
  - {face: xmin, fix: all}
loads:
  - {group: tip, force: [0, 0, -100.0]}
solver: {mode: linear}
output:
  probes:
    w: {group: tip, quantity: displacement, component: z, reduce: mean}
"""


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rbsm_dyn", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=600)


def test_sweep_over_seeds_and_young(tmp_path):
    """Two seeds × two Young's moduli: four runs.  Linear elasticity: the
    tip deflection of each mesh scales as 1/E (30/36 to 1e-9); the two
    meshes differ (deflections apart by more than 0.1 %); a run of the
    sweep is the case run on its own with that seed (bitwise); the table
    gives each E's mean over the seeds."""
    (tmp_path / "bar.yaml").write_text(BAR)
    r = cli("sweep", "bar.yaml", "--seeds", "1..2", "--set", "materials.c.young=30e9,36e9",
            "--jobs", "2", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(tmp_path / "bar_sweep" / "sweep.csv")))
    assert len(rows) == 4 and all(row["exit"] == "0" for row in rows)
    w = {(int(row["seed"]), float(row["materials.c.young"])): float(row["w_peak"])
         for row in rows}
    for seed in (1, 2):
        assert abs(w[seed, 36e9] / w[seed, 30e9] - 30 / 36) < 1e-9
    assert abs(w[1, 30e9] - w[2, 30e9]) > 1e-3 * abs(w[1, 30e9])
    (tmp_path / "alone.yaml").write_text(BAR.replace("seed: 1", "seed: 2"))
    assert cli("alone.yaml", "--out", "alone.h5", "--quiet", cwd=tmp_path).returncode == 0
    alone = rbsm_dyn.open_history(tmp_path / "alone.h5").observables["w"]
    assert alone[-1] == w[2, 30e9]
    mean = 0.5 * (w[1, 30e9] + w[2, 30e9])
    assert f"| 3e+10 | w (peak) | {mean:.6g} |" in r.stdout


def test_sweep_refuses_what_varies_nothing_or_is_bad(tmp_path):
    (tmp_path / "bar.yaml").write_text(BAR)
    blocks = BAR.replace("{kind: voronoi, size: 0.01, seed: 1}",
                         "{kind: blocks, divisions: [10, 1, 1]}")
    (tmp_path / "blocks.yaml").write_text(blocks)
    for args, words in ((["bar.yaml"], "--seeds or --set"),
                        (["bar.yaml", "--seeds", "3..1"], "backwards"),
                        (["bar.yaml", "--set", "materials.c.young=-1"], "materials.c.young"),
                        (["blocks.yaml", "--seeds", "1..2"], "no Voronoi mesh")):
        r = cli("sweep", *args, cwd=tmp_path)
        assert r.returncode == 2 and words in r.stderr, (args, r.stderr)
        assert "Traceback" not in r.stderr
