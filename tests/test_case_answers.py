"""The expected answers stated in the headers of three cases, computed from
runs of the case files themselves (issue 17: "the expected answer at the
top of every case is computed by a test").

Each test reads cases/<name>.yaml, takes the numbers of the reference
formula (dimensions, E, σ0, f_t, G_f, loads) from that file, runs the file
unchanged (only the output file is chosen here) and checks the header's
answer against the formula, with a tolerance argued from the physics or
the reference the header cites, not from the code's own output:

* impulsive_beam.yaml: rigid-plastic W_f = m V0² L²/(3 Mp) and
  T = m V0 L²/(2 Mp) (Jones, Structural Impact, §3.3), lifted by elastic
  effects (VERIFICATION C);
* brazilian_disc.yaml: the disc splits along the loaded diameter when
  2P/(πDt) reaches the splitting strength, about f_t (ASTM C496,
  EN 12390-6; Timoshenko & Goodier §41);
* three_point_bending.yaml: elastic CMOD/P (Tada, Paris & Irwin 2.13), work
  of fracture against G_f (RILEM TC-50 FMC-1), peak load between the
  strength-of-materials bounds of the ligament.

Run times (2 shared cores, one thread, the other core busy): about 15 s,
2.5 min and 4 min.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.case import load_case
from rbsm_dyn.model import build_mesh

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "cases"
BROKEN = 2          # physics/laws: 0 elastic, 1 yielded, 2 broken, 3 contact


def _run(name: str, tmp_path_factory) -> tuple[dict, "rbsm_dyn.History"]:
    """Run cases/<name> itself (only --out chosen here); return its parsed
    text and its history."""
    path = CASES / name
    out = tmp_path_factory.mktemp(Path(name).stem) / "run.h5"
    code = main([str(path), "--out", str(out), "--quiet"])
    assert code == 0, f"cases/{name} exited {code}"
    return yaml.safe_load(path.read_text(encoding="utf-8")), rbsm_dyn.open_history(out)


# --------------------------------------------------------------------------
# impulsive_beam.yaml
# --------------------------------------------------------------------------

def test_impulsive_beam_deflection_and_duration_above_rigid_plastic(tmp_path_factory):
    """cases/impulsive_beam.yaml: a simply supported beam, span 2L, every
    cell at V0 downward.  Rigid-perfectly-plastic theory (Jones, Structural
    Impact, §3.3): m = ρbH, Mp = σ0 b H²/4, W_f = m V0² L²/(3 Mp) = 20.91 mm,
    T = m V0 L²/(2 Mp) = 2.24 ms, computed here from the case file's numbers.

    W_f = −min(mid_z).  Elastic effects lift an elastic–plastic beam above
    rigid-plastic theory: about +30 % at E/σ0 ≈ 10³ (VERIFICATION C3: 800)
    and about +15 % at E/σ0 = 10⁴; the case's E/σ0 = 2000 lies between, so
    W_f / W_f,rp ∈ [1.15, 1.30] (the header's wording).

    T = the first time after the start that mid_vz returns to ≥ 0.  Elastic
    effects lengthen the response (the elastic phase before the hinges form
    and the elastic bending that adds to the plastic deflection at the end);
    they cannot shorten it below the rigid-plastic time, whose plastic work
    alone absorbs the kinetic energy: T / T_rp ∈ [1.0, 1.3], the same +30 %
    ceiling as for W_f (VERIFICATION C: "tol 10–20 %"; the duration is
    less sensitive than the deflection)."""
    case, h = _run("impulsive_beam.yaml", tmp_path_factory)
    (x0, y0, z0), (x1, y1, z1) = case["domain"]["box"]
    (mat,) = case["materials"].values()
    rho, E, sigma0 = float(mat["density"]), float(mat["young"]), float(mat["yield"]["stress"])
    V0 = -float(case["initial"][0]["velocity"][2])
    L, b, H = (x1 - x0) / 2, y1 - y0, z1 - z0
    m, Mp = rho * b * H, sigma0 * b * H ** 2 / 4
    wf_rp = m * V0 ** 2 * L ** 2 / (3 * Mp)
    T_rp = m * V0 * L ** 2 / (2 * Mp)
    assert wf_rp == pytest.approx(20.91e-3, rel=1e-3)          # the header's figures
    assert T_rp == pytest.approx(2.24e-3, rel=2e-3)
    assert 1e3 <= E / sigma0 <= 1e4                            # between VERIFICATION C's two

    t, z, vz = h.time, h.observables["mid_z"], h.observables["mid_vz"]
    wf = -z.min()
    assert 1.15 <= wf / wf_rp <= 1.30, f"W_f = {wf * 1e3:.2f} mm = {wf / wf_rp:.3f} × rigid-plastic"
    assert vz[0] == pytest.approx(-V0)
    back = np.nonzero((t > 0) & (vz >= 0))[0]
    assert len(back), "the midspan never stopped within the run"
    T = t[back[0]]
    assert 1.0 <= T / T_rp <= 1.30, f"T = {T * 1e3:.3f} ms = {T / T_rp:.3f} × rigid-plastic"


# --------------------------------------------------------------------------
# brazilian_disc.yaml
# --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def brazilian(tmp_path_factory):
    case, h = _run("brazilian_disc.yaml", tmp_path_factory)
    path = CASES / "brazilian_disc.yaml"
    mesh = build_mesh(load_case(path))
    cyl = case["domain"]["cylinder"]
    R, t = float(cyl["radius"]), float(np.linalg.norm(cyl["axis"]))
    (load_top, _) = case["loads"]
    assert load_top["surface"] == "top_strip"
    # P per unit pressure: the strip's area projected on the loaded diameter (z)
    strip = mesh.bface_side == mesh.surface_names.index("cylinder0.top_strip")
    area_z = float(np.sum(mesh.bface_area[strip] * mesh.bface_normal[strip, 2]))
    hist = np.asarray(load_top["history"], dtype=float)
    P = float(load_top["pressure"]) * area_z * np.interp(h.time, hist[:, 0], hist[:, 1])
    conc = case["materials"]["concrete"]
    p = dict(R=R, D=2 * R, t=t, P=P, ft=float(conc["rupture"]["tensile_strength"]),
             E=float(conc["young"]), h=float(case["mesh"]["size"]),
             bearing=[case["groups"][g]["box"] for g in ("bearing_top", "bearing_bottom")])
    return h, p


def test_brazilian_disc_splits_at_the_splitting_strength(brazilian):
    """cases/brazilian_disc.yaml: the load P on each strip is the case's
    pressure ramp times the strip's projected area (from the mesh of the
    case file).  The disc splits when the centre's horizontal stress
    2P/(πDt) (Hertz; Timoshenko & Goodier §41; the model's elastic centre
    stress is within 5 %, tests/test_brazilian_disc.py) reaches the
    splitting strength.  The splitting load is taken where the first faces
    break (the header: "the opening across the centre runs away and the
    first faces break").

    Band: f_t ≤ 2P/(πDt) ≤ 1.5 f_t.  Below: no face can break before the
    largest tension reaches f_t, and under the strips' spread load the
    centre's tension 2P/(πDt) is the disc's largest (Hondros 1959; 5 % for
    the model's elastic error).  Above: the splitting strength of concrete
    is f_t/0.9 = 1.11 f_t (CEB-FIP MC 1990), and small discs (here
    D = 0.1 m against l_ch = E G_f/f_t² = 0.33 m) split above it, up to
    about 1.3 f_t (Rocco, Guinea, Planas & Elices 1999, size effect in the
    Brazilian test); the header states 1.25 f_t; 1.5 leaves room for the
    random mesh.  The first faces break in the middle of the disc, where
    the tension is (|x| ≤ 3 cells, |z| ≤ R/2), not under the strips; and
    the split runs away: the opening across the centre (probe `opening`)
    grows to at least 3 × its value in the frame before the first break."""
    h, p = brazilian
    st = h.spring_state
    assert st is not None, "the case writes no spring_state"
    new = (st >= BROKEN) & ~(st[0] >= BROKEN)
    broke = np.nonzero(new.any(axis=1))[0]
    assert len(broke), "the disc did not break"
    k = broke[0]
    sigma = 2 * p["P"] / (math.pi * p["D"] * p["t"])
    # the first break lies between frames k−1 and k: the band holds at both
    lo, hi = sigma[k - 1] / p["ft"], sigma[k] / p["ft"]
    assert 1.0 - 0.05 <= lo and hi <= 1.5, (
        f"first faces break at 2P/(πDt) between {lo:.3f} and {hi:.3f} f_t")
    first = h.static["springs/position"][new[k]]
    assert np.all(np.abs(first[:, 0]) <= 3 * p["h"]) and np.all(np.abs(first[:, 2]) <= p["R"] / 2), (
        f"the first faces break at x, z = {first[:, [0, 2]].tolist()}")
    opening = h.observables["opening"]
    assert opening[-1] >= 3 * opening[k - 1], (
        f"opening {opening[k - 1]:.3g} m before the break, {opening[-1]:.3g} m at the end")


def test_brazilian_disc_crack_lies_along_the_loaded_diameter(brazilian):
    """The faces broken in the run (not by the end cut: the case has none)
    lie along the loaded diameter x = 0: 80 % of their area within four
    cells (|x| ≤ 4 h = D/10) of it, and the crack crosses the disc between the
    bearing strips (broken faces near the centre and within two cells of
    both bearing zones' edges).  A Voronoi crack meanders over a cell or
    two; the wedges under the strips may break off sideways (the 20 %)."""
    h, p = brazilian
    st = h.spring_state
    new = (st[-1] >= BROKEN) & ~(st[0] >= BROKEN)
    pos = h.static["springs/position"][new]
    area = h.static["springs/area"][new]
    assert len(pos)
    near = np.abs(pos[:, 0]) <= 4 * p["h"]
    assert area[near].sum() >= 0.8 * area.sum(), (
        f"{area[near].sum() / area.sum():.2f} of the broken area within 4 cells of x = 0")
    z = pos[near, 2]
    top = p["bearing"][0][0][2]        # the bearing cells' lower edge, z = 0.041
    bottom = p["bearing"][1][1][2]     # z = −0.041
    assert np.any(np.abs(z) <= p["h"]), "no broken face at the centre"
    assert z.max() >= top - 2 * p["h"] and z.min() <= bottom + 2 * p["h"], (
        f"the crack spans z ∈ [{z.min():.3f}, {z.max():.3f}] m only")


# --------------------------------------------------------------------------
# three_point_bending.yaml
# --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def tpb(tmp_path_factory):
    case, h = _run("three_point_bending.yaml", tmp_path_factory)
    parts = case["parts"]
    (bx0, by0, bz0), (bx1, by1, bz1) = parts["beam"]["geometry"]["box"]
    span = (np.mean(np.asarray(parts["roller"]["geometry"]["box"])[:, 0])
            - np.mean(np.asarray(parts["pin"]["geometry"]["box"])[:, 0]))
    within = np.asarray(case["cuts"][0]["within"])
    conc = case["materials"]["concrete"]
    p = dict(S=span, W=by1 - by0, b=bz1 - bz0, a0=within[1, 1] - by0,
             E=float(conc["young"]), ft=float(conc["rupture"]["tensile_strength"]),
             Gf=float(conc["rupture"]["fracture_energy"]))
    ob = h.observables
    # the platen's reaction is −y on the platen: the load on the beam is −P
    p["load"], p["cmod"], p["delta"] = -ob["P"], ob["cmod"], -ob["deflection"]
    return h, p


def _tada_cmod_per_load(p):
    """Tada, Paris & Irwin 2.13 (S/W = 4): CMOD = 4 σ a V1(α)/E',
    σ = 1.5 P S/(b W²), V1(α) = 0.76 − 2.28α + 3.87α² − 2.04α³ + 0.66/(1−α)²."""
    a = p["a0"] / p["W"]
    v1 = 0.76 - 2.28 * a + 3.87 * a ** 2 - 2.04 * a ** 3 + 0.66 / (1 - a) ** 2
    sigma_per_p = 1.5 * p["S"] / (p["b"] * p["W"] ** 2)
    return 4 * sigma_per_p * p["a0"] * v1 / p["E"]


def test_three_point_bending_elastic_cmod_compliance(tpb):
    """(a) The initial compliance CMOD/P against Tada, Paris & Irwin 2.13
    computed from the beam's dimensions and E in the case file (2.97e-8
    m/N, plane stress): the secant CMOD/P of the load steps up to half the
    peak, the initial compliance C_i of RILEM TC-89-FMT (Jenq & Shah 1985):
    beyond about half the peak a notched concrete beam is no longer linear
    (the softening zone at the notch tip grows before the peak).  The case
    runs statically (Newton under CMOD control): the first step, 35 % of the
    peak, is on the elastic branch.

    Tolerance ±10 %: the handbook formula is good to 1 % at S/W = 4, but
    the beam (b/W = 0.4) lies between plane stress and plane strain
    (E/(1−ν²), ν = 0.2: 4 % stiffer), the rollers and platen indent the
    beam's faces through their contact springs, and the notch-tip springs
    start softening below half the peak.  The header's figure: −4.1 %."""
    h, p = tpb
    ref = _tada_cmod_per_load(p)
    assert ref == pytest.approx(2.97e-8, rel=5e-3)              # the header's figure
    P, cmod = p["load"], p["cmod"]
    k_peak = int(np.argmax(P))
    pre = np.arange(k_peak + 1)
    sel = pre[(P[pre] > 0.0) & (P[pre] <= 0.5 * P[k_peak])]
    assert len(sel) >= 1, "no load step below half the peak"
    compliance = cmod[sel] / P[sel]
    assert compliance == pytest.approx(np.full(len(sel), ref), rel=0.10), (
        f"CMOD/P = {compliance} m/N, Tada {ref:.4g}")


def test_three_point_bending_work_of_fracture(tpb):
    """(b) RILEM TC-50 FMC-1: G_f = W/(b (W − a0)), W = ∫ P dδ the area
    under the load – load-point displacement curve (δ the platen's
    displacement) followed to P = 0 (the beam's own weight is not in the
    model: gravity is off).  The run stops at about 30 % of the peak
    (control.stop_fraction), so
    its work is below the full area: W_run/A < G_f.  The tail beyond the
    end carries less than 40 %: Elices, Guinea & Planas (1992, "Measurement
    of the fracture energy using three-point bend tests", Part 3) show the
    far tail P ≈ A/δ², whose unmeasured work beyond δ_u is P_u δ_u; here
    that estimate is asserted below 0.4 G_f A, so W_run/A > 0.6 G_f, and
    the run's work plus that tail estimate is G_f within ±25 % (the
    hyperbolic tail is an asymptote; the run's work also holds the elastic
    energy still stored at the end)."""
    h, p = tpb
    P, d = p["load"], p["delta"]
    A = p["b"] * (p["W"] - p["a0"])
    work = float(np.sum(0.5 * (P[1:] + P[:-1]) * np.diff(d)))
    g_run = work / A
    assert P[-1] < 0.4 * P.max(), "the run did not reach the softening tail"
    assert 0.6 * p["Gf"] < g_run < p["Gf"], f"W/(b(W−a0)) = {g_run:.1f} J/m²"
    tail = P[-1] * d[-1] / A
    assert tail < 0.4 * p["Gf"], f"tail estimate {tail:.1f} J/m²"
    assert g_run + tail == pytest.approx(p["Gf"], rel=0.25), (
        f"run {g_run:.1f} + tail {tail:.1f} J/m² against G_f = {p['Gf']}")


def test_three_point_bending_peak_between_ligament_bounds(tpb):
    """(c) No single closed formula gives the peak of a cohesive notched
    beam within ±25 % at this size (D = 0.1 m against l_ch = E G_f/f_t² =
    0.33 m: the size-effect law needs the fracture-process length c_f,
    which the case does not state), so the test brackets it instead:

    * above the elastic net-section estimate f_t b (W−a0)²/(1.5 S) (the
      ligament's outer fibre at f_t, strength of materials; a cohesive
      ligament carries more, as its softening zone spreads);
    * below the tension cut-off limit load 2 f_t b (W−a0)²/S (no traction
      above f_t on the ligament, the compression at its top: the upper
      bound theorem of limit analysis);
    * below the LEFM load with K_Ic = √(E G_f) (Tada 2.13:
      K = σ√(πa) F(α), F = 1.090 − 1.735α + 8.20α² − 14.18α³ + 14.57α⁴):
      a cohesive crack peaks below LEFM (Bažant & Planas 1998, size effect).
    The header's 1 003.5 N lies in [500 N, 1500 N]."""
    h, p = tpb
    lig = p["W"] - p["a0"]
    elastic_net = p["ft"] * p["b"] * lig ** 2 / (1.5 * p["S"])
    plastic = 2 * p["ft"] * p["b"] * lig ** 2 / p["S"]
    a = p["a0"] / p["W"]
    F = 1.090 - 1.735 * a + 8.20 * a ** 2 - 14.18 * a ** 3 + 14.57 * a ** 4
    sigma = math.sqrt(p["E"] * p["Gf"]) / (math.sqrt(math.pi * p["a0"]) * F)
    lefm = sigma * p["b"] * p["W"] ** 2 / (1.5 * p["S"])
    peak = float(p["load"].max())
    assert elastic_net < peak < min(plastic, lefm), (
        f"peak {peak:.0f} N; net-section {elastic_net:.0f}, limit {plastic:.0f}, "
        f"LEFM {lefm:.0f} N")
