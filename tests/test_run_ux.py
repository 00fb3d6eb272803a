"""What a run tells its user (issue 17, items 2, 3, 7 and 9): the results
on screen at the end, progress and the compile notice, contradictions and
unit traps found by check, a whole part given a rigid initial motion."""
import re
import textwrap

import numpy as np
import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main

from post_case import TINY

STATIC = (TINY.replace("initial: [{group: tip, velocity: [0, 0, -1.0]}]",
                       "loads: [{group: tip, force: [0, 0, -1.0e3]}]")
          .replace("solver: {mode: dynamic, end_time: 1.0e-5}",
                   "solver: {mode: static, method: newton, load_steps: 2}"))

#: TINY in mm-N-s (same values)
TINY_MM = (TINY.replace("name: good", "name: good\nunits: mm-N-s")
           .replace("[[0, 0, 0], [0.4, 0.1, 0.1]]", "[[0, 0, 0], [400, 100, 100]]")
           .replace("density: 8000, young: 200.0e9", "density: 8.0e-9, young: 200.0e3")
           .replace("[[0.35, -1, -1], [1, 1, 1]]", "[[350, -1000, -1000], [1000, 1000, 1000]]")
           .replace("velocity: [0, 0, -1.0]", "velocity: [0, 0, -1000.0]"))


def _write(tmp_path, text, name="case.yaml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------ item 2: results on screen ---

def test_dynamic_run_prints_the_probes_last_values(tmp_path, capsys):
    path = _write(tmp_path, TINY)
    out = tmp_path / "run.h5"
    assert main([str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    h = rbsm_dyn.open_history(out)
    m = re.search(r"tip_z = (\S+) m\b", text)
    assert m, text
    assert float(m.group(1)) == pytest.approx(h.observables["tip_z"][-1], rel=1e-5)
    assert "history in SI" not in text          # an SI case: nothing to say


def test_static_run_prints_reaction_and_residual(tmp_path, capsys):
    path = _write(tmp_path, STATIC)
    out = tmp_path / "static.h5"
    assert main([str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    m = re.search(r"reaction = \[(\S+), (\S+), (\S+)\] N", text)
    assert m, text
    assert float(m.group(3)) == pytest.approx(1.0e3, rel=1e-3)   # holds the 1 kN load
    assert re.search(r"residual = \S+ ", text), text
    assert re.search(r"tip_z = -\S+ m", text), text


def test_mm_case_summary_says_the_history_is_in_si(tmp_path, capsys):
    path = _write(tmp_path, TINY_MM)
    out = tmp_path / "mm.h5"
    assert main([str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "history in SI units" in text and "mm-N-s" in text, text
    m = re.search(r"tip_z = (\S+) m \((\S+) mm\)", text)
    assert m, text
    assert float(m.group(2)) == pytest.approx(1e3 * float(m.group(1)), rel=1e-5)


def test_info_names_the_file_a_run_would_write(tmp_path, capsys):
    path = _write(tmp_path, TINY)
    assert main(["info", str(path), "--out", str(tmp_path / "elsewhere.h5")]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("output")][0]
    assert "elsewhere.h5" in line and "good.h5" not in line, line
    assert main(["info", str(path)]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("output")][0]
    assert "-> good.h5" in line, line


# --------------------------------- item 3: start-up, progress, batch jobs ---

from rbsm_dyn import __main__ as cli


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_eta_starts_after_the_first_chunk():
    """50 s of compilation in the first chunk of 10 steps, then 10 steps/s:
    the ETA is the 8 s left, not the 200 s an average from the start gives."""
    clock = Clock()
    p = cli.Progress(True, style="log", clock=clock)
    p.start(100, 1e-6)
    assert p.eta(0) is None
    clock.t = 50.0
    p.update(10, 1e-5, 0.0)
    assert p.eta(10) is None                 # one chunk: no rate yet
    clock.t = 51.0
    p.update(20, 2e-5, 0.0)
    assert p.eta(20) == pytest.approx(8.0)


def test_batch_progress_logs_every_30_s_and_10_percent(capsys):
    clock = Clock()
    p = cli.Progress(True, style="log", clock=clock)
    p.start(1000, 1e-6)
    for k in range(1, 1001):                  # 1 step per second: 1000 s
        clock.t = float(k)
        p.update(k, k * 1e-6, 1.0)
    p.close()
    lines = capsys.readouterr().err.strip().splitlines()
    # 10 % = 100 s between lines (later than 30 s): 10 lines
    assert len(lines) == 10, lines
    assert all(line.startswith("rbsm_dyn: progress ") for line in lines)
    assert "progress 50 % (step 500/1000" in lines[4], lines[4]
    assert "ETA 8 min 20 s" in lines[4], lines[4]
    # a short run: 30 s between lines
    p = cli.Progress(True, style="log", clock=clock)
    clock.t = 0.0
    p.start(10, 1e-6)
    for k in range(1, 11):
        clock.t = 10.0 * k                    # 100 s in all, 10 % per 10 s
        p.update(k, k * 1e-6, 1.0)
    assert len(capsys.readouterr().err.strip().splitlines()) == 3   # at 30, 60, 90 s


def test_quiet_and_rbsm_progress_off_log_nothing(capsys, monkeypatch):
    clock = Clock()
    monkeypatch.setenv("RBSM_PROGRESS", "0")
    for p in (cli.Progress(False, clock=clock), cli.Progress(True, clock=clock)):
        p.start(10, 1.0)
        for k in range(1, 11):
            clock.t = 100.0 * k
            p.update(k, k, 1.0)
        assert not p.enabled
    assert capsys.readouterr().err == ""
    monkeypatch.setenv("RBSM_PROGRESS", "log")
    assert cli.progress_style() == "log"
    monkeypatch.setenv("RBSM_PROGRESS", "1")
    assert cli.progress_style() == "bar"
    monkeypatch.delenv("RBSM_PROGRESS")
    assert cli.progress_style() == "log"      # pytest's stderr is no terminal


def test_static_bar_counts_whole_load_steps():
    p = cli.Progress(True, style="bar", kind="load steps")
    p.start(4, 1.0)
    p.update(0.7, 0.25, 1e-3, label="residual")     # load step 1 at 70 %
    assert p.bar.n == 0
    p.update(1.0, 0.25, 1e-7, label="residual")     # load step 1 done
    assert p.bar.n == 1
    p.update(2.9999, 0.75, 1e-5, label="residual")
    assert p.bar.n == 2
    p.close()
    p = cli.Progress(True, style="bar", kind="newton")
    p.start(100, 1.0)
    p.update(100 * 0.337, 0.337, 1e-9, label="residual")
    assert p.bar.n == 33 and "increment 1" in str(p.bar)
    p.close()


def test_help_documents_rbsm_progress(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "RBSM_PROGRESS" in text and "compiling kernels" in text


def test_cold_kernel_detection(tmp_path):
    """A kernel never compiled is cold; once called it is warm, and a fresh
    dispatcher of the same source finds it in the cache index."""
    import importlib.util
    src = tmp_path / "kernel_probe_mod.py"
    src.write_text("import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n")

    def load(name):
        spec = importlib.util.spec_from_file_location(name, src)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod

    m1 = load("kernel_probe_a")
    assert cli.kernel_is_cold(m1.f) is True
    assert m1.f(1) == 2
    assert cli.kernel_is_cold(m1.f) is False
    m2 = load("kernel_probe_b")
    assert cli.kernel_is_cold(m2.f) is False          # from the index on disk
    assert cli.kernel_is_cold(len) is None            # cannot tell
    # the package's kernels have run in this test session (test above)
    assert cli.cold_kernels(["dynamic"]) == []


def test_cold_start_notice_and_its_timing(tmp_path, capsys, monkeypatch):
    """A cold start says so before the build, with the time it expects;
    the time it took is kept for the next notice."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    calls = []

    def cold_once(kinds):        # cold before the run, warm after it
        calls.append(kinds)
        return [k for k in kinds if k == "dynamic"] if len(calls) == 1 else []

    from rbsm_dyn.cli import notice              # (where CompileNotice looks it up)
    monkeypatch.setattr(notice, "cold_kernels", cold_once)
    monkeypatch.setattr(cli.CompileNotice, "MIN_SECONDS", 0.0)
    path = _write(tmp_path, TINY)
    assert main([str(path), "--out", str(tmp_path / "run.h5")]) == 0
    err = capsys.readouterr().err
    expect = f"compiling kernels (first run only, about {cli.COMPILE_SECONDS['dynamic']:.0f} s)"
    assert expect in err, err
    import json
    seen = json.loads((tmp_path / "xdg" / "rbsm_dyn" / "compile_seconds.json").read_text())
    assert set(seen) == {"dynamic"} and 0 <= seen["dynamic"] < 60
    assert main([str(path), "--out", str(tmp_path / "run.h5"), "--quiet"]) == 0
    assert "compiling" not in capsys.readouterr().err



HEARTBEAT = re.compile(r"^rbsm_dyn: still compiling kernels \((\d+) s so far\)$", re.M)


def test_heartbeat_beats_until_done_and_never_after(monkeypatch):
    """The heartbeat of a cold notice says a line every Heartbeat.SECONDS
    (counting them) until done(); a quiet notice says nothing; a warm one
    starts only when armed (the solver's start)."""
    import time
    from rbsm_dyn.cli import notice
    lines = []
    monkeypatch.setattr(notice.Heartbeat, "SECONDS", 0.05)
    monkeypatch.setattr(notice.CompileNotice, "_say", lambda self, text: lines.append(text))
    monkeypatch.setattr(notice, "cold_kernels", lambda kinds: list(kinds))
    monkeypatch.setattr(notice, "compile_seconds", lambda kinds: 1.0)
    n = notice.CompileNotice(["build"], announce=False)     # (check, info)
    time.sleep(0.4)
    n.done()
    said = len(lines)
    time.sleep(0.2)
    assert len(lines) == said >= 3, lines
    assert [HEARTBEAT.match(x) is not None for x in lines] == [True] * said, lines
    lines.clear()
    notice.CompileNotice(["build"], enabled=False).arm()     # --quiet
    monkeypatch.setattr(notice, "cold_kernels", lambda kinds: [])
    warm = notice.CompileNotice(["dynamic"])
    time.sleep(0.2)
    assert lines == []
    warm.arm()
    time.sleep(0.2)
    warm.cancel()
    said = len(lines)
    time.sleep(0.2)
    assert len(lines) == said >= 1


def _cold_cli(tmp_path, *args):
    """python -m rbsm_dyn ARGS in a subprocess with an empty kernel cache
    (XDG_CACHE_HOME, no NUMBA_CACHE_DIR inherited) and the heartbeat every
    1 s instead of 10 (a tiny case's build compiles for a few seconds)."""
    import os
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(XDG_CACHE_HOME=str(tmp_path / "xdg"), NUMBA_NUM_THREADS="1")
    script = textwrap.dedent("""\
        import sys
        from rbsm_dyn.cli import notice
        notice.Heartbeat.SECONDS = 1.0
        from rbsm_dyn.__main__ import main
        sys.exit(main(sys.argv[1:]))
        """)
    r = subprocess.run([sys.executable, "-c", script, *map(str, args)], env=env,
                       capture_output=True, text=True, timeout=900)
    # the cache was empty, and kernels were compiled into it
    assert list((tmp_path / "xdg" / "rbsm_dyn").glob("numba-*/**/*.nbi")), r.stderr
    return r


def test_cold_check_says_it_is_still_compiling(tmp_path):
    """check (and info) say no compile notice, but while a cold build
    compiles its kernels a line every Heartbeat.SECONDS: never a long
    silence."""
    path = _write(tmp_path, TINY)
    r = _cold_cli(tmp_path, "check", path)
    assert r.returncode == 0, r.stderr
    beats = [int(x) for x in HEARTBEAT.findall(r.stderr)]
    assert beats and beats == list(range(1, len(beats) + 1)), r.stderr
    assert "first run only" not in r.stderr, r.stderr
    assert r.stdout.startswith(f"{path}: ok"), r.stdout


def test_quiet_silences_the_heartbeat(tmp_path):
    path = _write(tmp_path, TINY)
    r = _cold_cli(tmp_path, "check", path, "--quiet")
    assert r.returncode == 0, r.stderr
    assert "compiling" not in r.stderr, r.stderr
    assert r.stdout.startswith(f"{path}: ok"), r.stdout

PLANE = """
name: plane-tiny
plane: {kind: stress, thickness: 0.01}
domain: {box: [[0, 0], [0.1, 0.02]]}
mesh: {kind: blocks, divisions: [10, 2]}
materials: {steel: {density: 7800, young: 200.0e9, poisson: 0.3}}
boundary: [{face: xmin, fix: all}]
initial: [{velocity: [0, 1.0]}]
solver: {mode: dynamic, end_time: 1.0e-6}
"""

CASE_OF_KIND = {
    "dynamic": TINY, "plane": PLANE, "newton": STATIC, "relaxation": STATIC.replace("method: newton, ", "method: relaxation, "),
    "linear": STATIC.replace("mode: static, method: newton, load_steps: 2", "mode: linear"),
    "modal": STATIC.replace("mode: static, method: newton, load_steps: 2",
                            "mode: modal, modes: 3").replace(
        "loads: [{group: tip, force: [0, 0, -1.0e3]}]\n", ""),
}


@pytest.mark.parametrize("kind", sorted(CASE_OF_KIND))
def test_the_kernels_watched_are_those_a_run_calls(tmp_path, kind):
    """Every kernel RUN_KERNELS names for a kind (and for the build) is
    compiled by a run of that kind: else the notice would say "compiling"
    on every run."""
    import subprocess
    import sys
    path = _write(tmp_path, CASE_OF_KIND[kind])
    from rbsm_dyn.case import load_case
    assert cli._run_kind(load_case(path)) == kind
    # in a process of its own (here, earlier tests have compiled everything)
    script = textwrap.dedent(f"""\
        import importlib
        from rbsm_dyn import __main__ as cli
        assert cli.main([{str(path)!r}, "--out", {str(tmp_path / "k.h5")!r}, "--quiet"]) == 0
        for mod, name in cli.RUN_KERNELS["build"] + cli.RUN_KERNELS[{kind!r}]:
            f = getattr(importlib.import_module("rbsm_dyn." + mod), name)
            if not f.signatures:
                print("not called:", mod, name)
        """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert "not called" not in r.stdout, r.stdout


def test_a_plane_scene_with_contact_watches_the_kernels_it_calls(tmp_path):
    """A plane scene with `contact` steps on the plane passes, the plane
    contact pass compiled into run_plane (its output frames on the 3D
    contact pass): every kernel its run kinds name is compiled by its run,
    so the notice does not say "compiling kernels" on every run."""
    import subprocess
    import sys
    from rbsm_dyn.case import load_case
    path = _write(tmp_path, PLANE + "contact: {between: all}\n")
    from rbsm_dyn.cli.notice import run_kinds
    kinds = run_kinds(load_case(path))
    assert kinds == ["plane", "contact"]
    script = textwrap.dedent(f"""\
        import importlib
        from rbsm_dyn import __main__ as cli
        assert cli.main([{str(path)!r}, "--out", {str(tmp_path / "k.h5")!r}, "--quiet"]) == 0
        for kind in ["build"] + {kinds!r}:
            for mod, name in cli.RUN_KERNELS[kind]:
                f = getattr(importlib.import_module("rbsm_dyn." + mod), name)
                if not f.signatures:
                    print("not called:", mod, name)
        """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert "not called" not in r.stdout, r.stdout


# ------------------------------- item 7: contradictions and unit traps ---

TWO_ITEMS = TINY.replace("boundary: [{face: xmin, fix: all}]",
                         "boundary:\n  - {face: xmin, fix: all}\n  - {group: tip, fix: [z]}\n"
                         "  - {group: tip, %s}")


@pytest.mark.parametrize("item", ["displacement: [null, null, -1.0e-4]",
                                  "velocity: [0, null, -1.0]"])
def test_fix_and_prescribed_z_on_one_group_is_an_error(tmp_path, capsys, item):
    text = TWO_ITEMS % item
    if "displacement" in item:
        text = text.replace("initial: [{group: tip, velocity: [0, 0, -1.0]}]\n", "")
    path = _write(tmp_path, text)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "boundary[1]" in err and "boundary[2]" in err and " z " in err, err
    assert re.search(r"case\.yaml:\d+: boundary\[2\]\.", err), err
    assert len(err.strip().splitlines()) == 1


def test_fix_x_and_velocity_z_on_one_group_stays_allowed(tmp_path, capsys):
    text = (TWO_ITEMS % "velocity: [null, null, -1.0]").replace("fix: [z]", "fix: [x, ry]")
    path = _write(tmp_path, text)
    assert main(["check", str(path)]) == 0, capsys.readouterr().err
    # two fixes of one component: harmless
    text = (TWO_ITEMS % "fix: [z, x]")
    assert main(["check", str(_write(tmp_path, text, "b.yaml"))]) == 0


@pytest.mark.parametrize("old, new, hint", [
    ("density: 8000", "density: 7.85e-9", "t/mm³"),          # mm-N-s density in SI
    ("young: 200.0e9", "young: 200.0e3", "MPa"),              # MPa in SI
])
def test_wave_speed_outside_range_warns(tmp_path, capsys, old, new, hint):
    path = _write(tmp_path, TINY.replace(old, new))
    assert main(["check", str(path)]) == 0
    captured = capsys.readouterr()
    warn = [x for x in captured.err.splitlines() if "warning" in x]
    assert len(warn) == 1, captured.err
    assert "materials.steel" in warn[0] and "wave speed" in warn[0] and hint in warn[0]
    path = _write(tmp_path, TINY, "fine.yaml")
    assert main(["check", str(path)]) == 0
    assert "wave speed" not in capsys.readouterr().err


def test_mm_case_given_si_density_warns(tmp_path, capsys):
    path = _write(tmp_path, TINY_MM.replace("density: 8.0e-9", "density: 8000"))
    from rbsm_dyn.case import load_case
    case = load_case(path)
    assert len(case.warnings) == 1 and "kg/m³" in case.warnings[0]
    assert load_case(_write(tmp_path, TINY_MM, "ok.yaml")).warnings == []


def test_check_reports_the_stable_step(tmp_path, capsys):
    path = _write(tmp_path, TINY)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    m = re.search(r"stable step (\S+) s \(estimate\); dt (\S+) s \(× dt_safety 0.8\), (\d+) "
                  r"steps", out)
    assert m, out
    from rbsm_dyn.case import load_case
    from rbsm_dyn.model import build_model
    est = build_model(load_case(path)).stable_dt()
    assert float(m.group(1)) == pytest.approx(est, rel=1e-3)
    assert float(m.group(2)) == pytest.approx(0.8 * est, rel=1e-3)


# ------------------------------------------------ item 9: rigid initial motion ---

SPIN = textwrap.dedent("""\
    name: spin
    domain: {box: [[0, 0, 0], [0.1, 0.08, 0.06]]}
    mesh: {kind: voronoi, size: 0.025, seed: 3}
    materials:
      steel: {density: 7850, young: 200.0e9, poisson: 0.2}
    initial: [{group: all, velocity: [1.0, -2.0, 0.5], rigid: {angular_velocity: [30.0, -50.0, 80.0]}}]
    solver: {mode: dynamic, end_time: 1.0e-5}
    output:
      interval: 1.0e-6
      fields: [position, orientation, velocity, angular_velocity]
    """)


def _spun(text):
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import apply_initial, build_model, new_state
    case = load_case_text(text)
    model = build_model(case)
    state = new_state(model)
    apply_initial(case, model, state)
    return case, model, state


def _momenta(mass, inertia, R, x, v, w):
    """(P, L about the centre of mass, kinetic energy, I_total about it)."""
    m = mass
    com = (m[:, None] * x).sum(0) / m.sum()
    r = x - com
    Ic = np.einsum("nij,nj,nkj->nik", R, inertia, R)            # R diag(I) Rᵀ
    L = (m[:, None] * np.cross(r, v)).sum(0) + np.einsum("nij,nj->i", Ic, w)
    ek = 0.5 * (m * (v * v).sum(1)).sum() + 0.5 * np.einsum("ni,nij,nj->", w, Ic, w)
    I_tot = Ic.sum(0) + np.einsum("n,nij->ij", m, (r * r).sum(1)[:, None, None] * np.eye(3)
                                  - r[:, :, None] * r[:, None, :])
    return (m[:, None] * v).sum(0), L, ek, I_tot, com


def test_rigid_spin_gives_the_assembled_angular_momentum_and_energy():
    case, model, state = _spun(SPIN)
    n = model.n_bodies
    R = state.body_rot[:n]
    wb = np.einsum("nki,nk->ni", R, state.body_angmom[:n]) / model.body_inertia
    w_cells = np.einsum("nij,nj->ni", R, wb)
    w = np.array([30.0, -50.0, 80.0])
    assert np.allclose(w_cells, w, rtol=0, atol=1e-12 * np.linalg.norm(w))
    P, L, ek, I_tot, com = _momenta(model.body_mass, model.body_inertia, R,
                                    state.body_pos[:n], state.body_vel[:n], w_cells)
    M = model.body_mass.sum()
    v0 = np.array([1.0, -2.0, 0.5])
    assert np.allclose(P, M * v0, rtol=1e-12)
    Iw = I_tot @ w
    assert np.linalg.norm(L - Iw) <= 1e-12 * np.linalg.norm(Iw)
    assert ek == pytest.approx(0.5 * M * v0 @ v0 + 0.5 * w @ I_tot @ w, rel=1e-12)
    # each cell: v + ω × (x_c − centre of mass)
    assert np.allclose(state.body_vel[:n], v0 + np.cross(w, state.body_pos[:n] - com),
                       rtol=0, atol=1e-13)


def test_rigid_center_and_the_old_meaning_of_angular_velocity():
    c = [0.0, 0.0, 0.0]
    _, model, state = _spun(SPIN.replace("rigid: {angular_velocity: [30.0, -50.0, 80.0]}",
                                         "rigid: {angular_velocity: [0, 0, 80.0], center: "
                                         "[0, 0, 0]}"))
    n = model.n_bodies
    x = state.body_pos[:n]
    assert np.allclose(state.body_vel[:n], np.array([1.0, -2.0, 0.5])
                       + np.cross([0, 0, 80.0], x - c), atol=1e-13)
    # without rigid: each cell spins about its own centroid, no translation from ω
    _, model, state = _spun(SPIN.replace("rigid: {angular_velocity: [30.0, -50.0, 80.0]}",
                                         "angular_velocity: [0, 0, 80.0]"))
    assert np.allclose(state.body_vel[:n], [1.0, -2.0, 0.5], rtol=0, atol=0)


def test_rigid_spin_in_mm_and_its_errors(tmp_path, capsys):
    from rbsm_dyn.case import CaseError, load_case_text
    case = load_case_text(TINY_MM.replace(
        "initial: [{group: tip, velocity: [0, 0, -1000.0]}]",
        "initial: [{group: tip, rigid: {angular_velocity: [0, 0, 5.0], center: [400, 0, 0]}}]"))
    assert case.initial[0].rigid.center == pytest.approx([0.4, 0.0, 0.0])
    assert case.initial[0].rigid.angular_velocity == [0, 0, 5.0]
    with pytest.raises(CaseError, match=r"initial\[0\]\.angular_velocity: give the angular"):
        load_case_text(TINY.replace("velocity: [0, 0, -1.0]}",
                                    "angular_velocity: [0, 0, 1], rigid: {angular_velocity: "
                                    "[0, 0, 1]}}"))
    with pytest.raises(CaseError, match=r"initial\[0\]\.rigid\.omega: unknown key 'omega'"):
        load_case_text(TINY.replace("velocity: [0, 0, -1.0]}", "rigid: {omega: [0, 0, 1]}}"))


def test_free_block_given_a_rigid_spin_turns_as_a_rigid_body(tmp_path):
    """A free Voronoi block: its angular momentum about the centre of mass
    and its energy are kept, and over the first steps its cells move as
    one rigid body (distances between cells kept to the strain level
    ρ v²/E the spin causes; positions those of the rigid rotation)."""
    from rbsm_dyn.physics.rotation import quat_matrix_np
    path = _write(tmp_path, SPIN)
    out = tmp_path / "spin.h5"
    assert main([str(path), "--out", str(out), "--quiet"]) == 0
    h = rbsm_dyn.open_history(out)
    import h5py
    with h5py.File(out, "r") as f:
        mass, inertia = (np.asarray(f[f"particles/bodies/{k}"][()]) for k in ("mass", "inertia"))
    t = np.asarray(h.time)
    w = np.array([30.0, -50.0, 80.0])
    v0 = np.array([1.0, -2.0, 0.5])
    first = None
    size = 0.1
    vmax = np.linalg.norm(w) * size + np.linalg.norm(v0)
    strain = 7850 * vmax ** 2 / 200e9                     # ρ v² / E
    for k in range(len(t)):
        x, v, om = (np.asarray(a[k]) for a in (h.position, h.velocity, h.angular_velocity))
        R = quat_matrix_np(np.asarray(h.orientation[k]))
        P, L, ek, I_tot, com = _momenta(mass, inertia, R, x, v, om)
        if first is None:
            first = (L, ek, com, x, I_tot)
            assert np.linalg.norm(L - I_tot @ w) <= 1e-12 * np.linalg.norm(I_tot @ w)
            assert ek == pytest.approx(0.5 * mass.sum() * v0 @ v0 + 0.5 * w @ I_tot @ w,
                                       rel=1e-12)
            continue
        L0, ek0, com0, x0, _ = first
        # angular momentum about the (moving) centre of mass: kept
        assert np.linalg.norm(L - L0) <= 1e-12 * np.linalg.norm(L0), k
        # energy: kinetic + strain kept (the spin strains the block a little)
        e = ek + float(h.observables["strain"][k])
        assert e == pytest.approx(ek0, rel=1e-7), k
        # rigid motion: the rotation by ω t about the centre of mass
        th = w * t[k]
        a = np.linalg.norm(th)
        K = np.array([[0, -th[2], th[1]], [th[2], 0, -th[0]], [-th[1], th[0], 0]]) / a
        Rw = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
        assert np.allclose(com, com0 + v0 * t[k], rtol=0, atol=1e-12)
        rigid = com + (x0 - com0) @ Rw.T
        assert np.abs(x - rigid).max() <= strain * size, (k, np.abs(x - rigid).max())
        d0 = np.linalg.norm(x0[:, None] - x0[None], axis=2)
        d = np.linalg.norm(x[:, None] - x[None], axis=2)
        assert np.abs(d - d0).max() <= strain * size, k
    assert len(t) >= 5


def test_a_note_while_running_is_said_at_once_and_restarts_the_eta(capsys):
    """Progress.note (a Newton run that goes back on its path, solvers/
    newton.py): the line is on stderr when it happens, not only at the end,
    and the ETA counts afresh from the next update (the path done before
    is done again); nothing with --quiet."""
    clock = Clock()
    p = cli.Progress(True, style="log", clock=clock)
    p.start(100, 1e-6)
    clock.t = 10.0
    p.update(10, 1e-5, 0.0)
    clock.t = 11.0
    p.update(20, 2e-5, 0.0)
    assert p.eta(20) is not None
    p.note("back to frame 0", restart=True)
    assert capsys.readouterr().err.strip() == "rbsm_dyn: back to frame 0"
    assert p.eta(20) is None
    clock.t = 12.0
    p.update(5, 5e-6, 0.0)
    assert p.eta(5) is None                  # one update since: no rate yet
    q = cli.Progress(False, clock=clock)
    q.note("said to no one")
    assert capsys.readouterr().err == ""
