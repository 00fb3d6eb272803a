"""A run that cannot finish is refused before it starts (issue 30 item 5):
`check` and a run exit 2 naming solver.end_time, the steps and the estimate
when the history would not fit on the disk, or the stepping would take more
than a day; --force runs it anyway.  The figures are far from the limits
on any machine: 1.2e12 steps of a 10-body bar (dt = 0.8 × L/c = 0.83 µs,
c = sqrt(E/ρ)) cannot be stepped in a day (it would need < 72 ns a step
for 36 spring points), and a frame every step is about 10^15 bytes."""
import textwrap
from pathlib import Path

from test_fuzz_case import cli

BAR = textwrap.dedent("""\
    name: long
    domain: {{box: [[0, 0, 0], [0.1, 0.01, 0.01]]}}
    mesh: {{kind: blocks, divisions: [10, 1, 1]}}
    materials: {{steel: {{young: 200.0e9, poisson: 0.0, density: 7800}}}}
    solver: {{mode: dynamic, end_time: {end}}}
    output: {{file: long.h5, interval: {every}}}
""")


def write(tmp_path, end, every):
    p = Path(tmp_path) / "long.yaml"
    p.write_text(BAR.format(end=end, every=every))
    return p


def test_a_history_larger_than_the_disk_is_refused(tmp_path):
    case = write(tmp_path, 1.0e6, 1.0e-6)
    for argv in (["check", str(case)], [str(case), "--quiet"]):
        code, out, err = cli(argv, cwd=tmp_path)
        assert code == 2, err
        assert "solver.end_time" in err and "steps" in err and "free in" in err, err
    assert not (Path(tmp_path) / "long.h5").exists()


def test_more_than_a_day_of_stepping_is_refused_and_force_runs_check(tmp_path):
    case = write(tmp_path, 1.0e6, 1.0e5)
    code, out, err = cli(["check", str(case)], cwd=tmp_path)
    assert code == 2, err
    assert "solver.end_time" in err and "of stepping" in err and "--force" in err, err
    code, out, err = cli(["check", str(case), "--force"], cwd=tmp_path)
    assert code == 0, err
