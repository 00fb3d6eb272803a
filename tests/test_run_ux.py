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
    monkeypatch.setattr(cli, "cold_kernels",
                        lambda kinds: [k for k in kinds if k == "dynamic"])
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
