"""`python -m rbsm_dyn bench` (issue 5): the summary line's contract and the
thread identity it reports.  Timings are printed, never asserted."""
import os
import re
import subprocess
import sys

LINE = re.compile(r"^bench: bodies=(\d+) springs=(\d+) steps=(\d+) threads=(\d+) "
                  r"physics=(\w+) ns_per_spring_step=([\d.]+) ns_per_body_step=(\d+)$")


def test_bench_line_and_thread_identity():
    p = subprocess.run([sys.executable, "-m", "rbsm_dyn", "bench", "--bodies", "60",
                        "--steps", "5", "--threads", "1,2", "--physics", "full",
                        "--repeat", "1"], capture_output=True, text=True, timeout=900,
                       env=dict(os.environ, NUMBA_NUM_THREADS="2"))
    assert p.returncode == 0, p.stderr
    rows = [LINE.match(line) for line in p.stdout.splitlines() if line.startswith("bench:")]
    assert len(rows) == 2 and all(rows)
    for m, threads in zip(rows, (1, 2)):
        bodies, springs, steps, nt = (int(m.group(i)) for i in range(1, 5))
        assert 30 <= bodies <= 120                  # Voronoi: about the requested 60 cells
        assert springs > 10 * bodies                # ~34 spring points per cell
        assert steps == 5 and nt == threads and m.group(5) == "full"
        # ns per body-step = ns per spring-step × springs / bodies (same wall time)
        ns_s, ns_b = float(m.group(6)), float(m.group(7))
        assert abs(ns_b - ns_s * springs / bodies) <= 0.01 * ns_b + 1
    assert "bitwise identical: yes" in p.stdout


def test_bench_rejects_bad_options():
    p = subprocess.run([sys.executable, "-m", "rbsm_dyn", "bench", "--threads", "x"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and "--threads" in p.stderr and "Traceback" not in p.stderr


def test_bench_sizes_table():
    """`bench --sizes`: one row per size, each in its own process, timed on
    1 and the default thread count, which is 1 below threads.SERIAL_SPRINGS
    (these models have a few thousand spring points)."""
    p = subprocess.run([sys.executable, "-m", "rbsm_dyn", "bench", "--sizes", "40,90",
                        "--seconds", "0.02", "--repeat", "1"], capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, p.stderr
    rows = [line.split("|")[1:-1] for line in p.stdout.splitlines()
            if line.startswith("| ") and not line.startswith("| bodies")]
    assert len(rows) == 2
    for cells in rows:
        bodies, springs = int(cells[0]), int(cells[1])
        assert springs > 10 * bodies
        assert int(cells[6]) == 1                     # default threads: serial when small
        per_body, per_spring = (int(x) for x in cells[11].split("+"))
        # the kernel's own per-spring arrays alone (bodies, arms, frame, k): ≥ 100 B
        assert per_spring >= 100 and per_body > 0
