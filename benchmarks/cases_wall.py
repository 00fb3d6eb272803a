"""Wall time of every shipped case run as a new user runs it, with the
default settings (issue 15: "the shipped cases with default settings in
the README with their wall times"):

    python benchmarks/cases_wall.py [--busy] [--out benchmarks/results/cases_wall.md]

Each case is its own `python -m rbsm_dyn CASE --out TMP --quiet` process
(no --threads: the default thread count); the wall time includes start-up,
the build and the history (Numba's cache warm: one warm-up run of the
smallest case first).  --busy runs `yes > /dev/null` beside them (a second
CPU-bound process, as on a shared machine).  Writes a Markdown table.
"""
import argparse
import datetime
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--busy", action="store_true", help="a `yes > /dev/null` beside the runs")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "cases_wall.md"))
    a = p.parse_args(argv)
    cases = sorted((ROOT / "cases").glob("*.yaml"))
    rows = []
    busy = subprocess.Popen(["yes"], stdout=subprocess.DEVNULL) if a.busy else None
    try:
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([sys.executable, "-m", "rbsm_dyn", str(ROOT / "cases" / "bar_wave.yaml"),
                            "--out", f"{tmp}/warm.h5", "--quiet", "--max-steps", "5"],
                           capture_output=True)
            for case in cases:
                t0 = time.perf_counter()
                r = subprocess.run([sys.executable, "-m", "rbsm_dyn", str(case), "--out",
                                    f"{tmp}/{case.stem}.h5", "--quiet"], capture_output=True,
                                   text=True)
                wall = time.perf_counter() - t0
                summary = (r.stdout + r.stderr).strip().splitlines()
                line = next((s for s in summary if s.startswith("rbsm_dyn: ") and "->" in s),
                            summary[-1] if summary else "")
                rows.append((case.name, wall, r.returncode, line.replace("|", "/")[:160]))
                print(rows[-1], flush=True)
    finally:
        if busy is not None:
            busy.kill()
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                         cwd=ROOT).stdout.strip()
    lines = [f"# Shipped cases, default settings{' beside `yes > /dev/null`' if a.busy else ''}",
             "", f"{now}, git {git}, {platform.machine()}, {os.cpu_count()} cores, "
             f"`python benchmarks/cases_wall.py{' --busy' if a.busy else ''}`; wall time of the "
             "whole process (start-up, build, run, history).", "",
             "| case | wall [s] | exit | summary |", "|---|---|---|---|"]
    lines += [f"| {n} | {w:.1f} | {c} | {s} |" for n, w, c, s in rows]
    Path(a.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
