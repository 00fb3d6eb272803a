# %% [markdown]
# # rbsm_dyn quickstart: a crack in a notched plate
#
# Runs a small case (a glass plate 30 × 30 × 3 mm with an edge notch, pulled
# apart suddenly), reads the history, plots a probe and the energy balance,
# and draws the crack.  It takes a few seconds (plus the Numba compilation the
# first time).
#
# This notebook is made from `examples/quickstart.py` by
# `python examples/sync_notebook.py`; the test suite runs the script
# (tests/test_examples.py).  Pictures are written to the folder `OUT`
# (environment variable `RBSM_EXAMPLE_OUT`, default `quickstart_out/`).

# %%
import os
import sys
from pathlib import Path

import matplotlib

if "ipykernel" not in sys.modules:      # a script: draw to files only
    matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import PolyCollection

import rbsm_dyn
from rbsm_dyn.__main__ import main

OUT = Path(os.environ.get("RBSM_EXAMPLE_OUT", "quickstart_out"))
OUT.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## The case
#
# A case is a YAML file (docs/case_file.md).  Voronoi cells of about 2 mm;
# springs break at a strain of 1e-3 (Kawai's rupture criterion) and then act
# as frictional contact; the notch is a `cut` (pre-broken faces); 15 MPa
# tension on the top and bottom rows of cells from t = 0.

# %%
CASE = """\
name: quickstart-crack
description: a small edge-notched glass plate pulled apart suddenly
domain: {box: [[0, 0, 0], [0.03, 0.003, 0.03]]}
mesh: {kind: voronoi, size: 0.002, seed: 3}
materials:
  glass: {density: 2500, young: 60.0e9, poisson: 0.2, rupture: {strain: 1.0e-3}, friction: 0.5}
groups:
  top: {box: [[-1, -1, 0.028], [1, 1, 1]]}
  bottom: {box: [[-1, -1, -1], [1, 1, 0.002]]}
cuts:
  - {point: [0, 0, 0.015], normal: [0, 0, 1], within: [[-1, -1, 0.013], [0.006, 1, 0.017]]}
loads:
  - {group: top, force: [0, 0, 1350.0]}
  - {group: bottom, force: [0, 0, -1350.0]}
solver: {mode: dynamic, end_time: 3.0e-5}
output:
  interval: 5.0e-7
  fields: [position, spring_state]
  probes:
    top_z: {group: top, quantity: displacement, component: z, reduce: mean}
"""
case_file = OUT / "quickstart.yaml"
case_file.write_text(CASE, encoding="utf-8")
history_file = OUT / "quickstart.h5"
# the same as `python -m rbsm_dyn info ...` and `python -m rbsm_dyn ... --out ...`
main(["info", str(case_file)])
code = main([str(case_file), "--out", str(history_file)])
assert code == 0, f"the run failed (exit {code})"

# %% [markdown]
# ## Reading the history
#
# `open_history` gives NumPy arrays (`h.position` is (frames, bodies, 3),
# `h.observables[...]` is (frames,)); `open_history(path, xarray=True)` gives
# an xarray Dataset instead, if xarray is installed.

# %%
h = rbsm_dyn.open_history(history_file)
print(h.frames, "frames,", h.n_bodies, "bodies,", h.n_springs, "spring points; status", h.status)
print("observables:", sorted(h.observables))
t_us = h.time * 1e6

# %% [markdown]
# ## A probe and the energy balance
#
# `top_z` is the mean z displacement of the top row.  The balance (see
# `History.energy_balance`): kinetic + strain (stored) + fracture and
# friction (dissipated) = initial energy + external work (supplied).

# %%
eb = h.energy_balance()
fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
ax1.plot(t_us, h.observables["top_z"] * 1e6)
ax1.set_ylabel("top_z [µm]")
ax1.grid(alpha=0.3)
for key in ("kinetic", "strain", "fracture", "plastic"):
    ax2.plot(t_us, h.observables[key] * 1e3, label=key)
ax2.plot(t_us, eb["supplied"] * 1e3, "k", lw=2, label="supplied (external work)")
ax2.plot(t_us, (eb["stored"] + eb["dissipated"]) * 1e3, "C3--", label="stored + dissipated")
ax2.set_xlabel("time [µs]")
ax2.set_ylabel("energy [mJ]")
ax2.legend(fontsize=8)
ax2.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(OUT / "probe_energy.png", dpi=90)
balance_error = float(np.max(np.abs(eb["error"])) / np.max(np.abs(eb["supplied"])))
print(f"energy balance error: {balance_error:.2%} of the supplied energy")

# %% [markdown]
# ## The crack
#
# A spring's state is 0 elastic, 1 yielded, 2 broken, 3 broken and in
# contact.  `h.geometry()` knows the cells and the faces (reference
# configuration) and moves them with the bodies.  Drawn here in the x–z
# plane at the last frame, displacements magnified 10 times: the cells'
# front faces (y = 0) in grey, the faces with a broken spring in red.
# `python -m rbsm_dyn render` draws the same in 3D (pyvista), and
# `python -m rbsm_dyn export` writes it for ParaView.

# %%
geom = h.geometry()
k = h.frames - 1
scale = 10.0
face_of_spring = h.static["springs/face"]
broken = np.unique(face_of_spring[(h.spring_state[k] >= 2) & (face_of_spring >= 0)])
xyz = geom.face_points(h.position[k], scale=scale)           # every internal face
cracks = [xyz[geom.face_ptr[f]:geom.face_ptr[f + 1]][:, [0, 2]] * 1e3 for f in broken]
bxyz = geom.bface_points(h.position[k], scale=scale)         # faces on the box sides
front = [f for f in range(geom.n_bfaces)
         if np.all(geom.bface_xyz[geom.bface_ptr[f]:geom.bface_ptr[f + 1], 1] < 1e-9)]
cells = [bxyz[geom.bface_ptr[f]:geom.bface_ptr[f + 1]][:, [0, 2]] * 1e3 for f in front]
fig, ax = plt.subplots(figsize=(6, 6))
ax.add_collection(PolyCollection(cells, facecolors="0.92", edgecolors="0.6", linewidths=0.4))
ax.add_collection(PolyCollection(cracks, facecolors="red", edgecolors="red", linewidths=1.0))
ax.autoscale_view()
ax.set_aspect("equal")
ax.set_xlabel("x [mm]")
ax.set_ylabel("z [mm]")
ax.set_title(f"broken faces at t = {h.time[k] * 1e6:.1f} µs (displacement × {scale:g})")
fig.savefig(OUT / "cracks.png", dpi=90)
n_broken_faces = len(broken)
crack_tip_x = max(xyz[geom.face_ptr[f]:geom.face_ptr[f + 1], 0].max() for f in broken)
print(f"{n_broken_faces} broken faces; crack area {h.observables['crack_area'][k] * 1e6:.1f} mm²; "
      f"the crack reaches x = {crack_tip_x * 1e3:.1f} mm")
