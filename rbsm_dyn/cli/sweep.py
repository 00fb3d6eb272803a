"""python -m rbsm_dyn sweep CASE.yaml --seeds 1..8 [--set KEY=V1,V2 ...]:
an ensemble of independent runs of one case (issue 29 item 6), the mesh
seeds of its Voronoi meshes and any case keys varied, run side by side as
processes (`python -m rbsm_dyn` each, one Numba thread), and the scatter of
its probes tabulated: per run the peak (the value of largest magnitude)
and the last value of every probe, then their mean, standard deviation,
least and largest over the runs.  The mesoscale statistics of a peak load.

Writes DIR/<run>.yaml, DIR/<run>.h5 and DIR/sweep.csv (DIR: --out, default
<case name>_sweep beside the working directory); prints the table as
Markdown.  Exit 0 when every run ends, 1 when some run fails (the table
marks it), 2 for a bad option or case, 130 on Ctrl-C (the runs are
stopped; their histories stay readable).  A failed run's probes are read
from its history as far as it got (its row says exit 1)."""
import argparse
import csv
import io
import itertools
import os
import subprocess
import sys
import time
from pathlib import Path


def parser():
    p = argparse.ArgumentParser(
        prog="python -m rbsm_dyn sweep",
        description="Run a case over mesh seeds and a grid of key values, side by side, "
                    "and tabulate the scatter of its probes.")
    p.add_argument("case", help="the case file (YAML)")
    p.add_argument("--seeds", help="mesh seeds of its Voronoi meshes: 1..8, 1,4,9 or "
                                   "1..4,9 (default: the case's own)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=V1,V2",
                   help="a case key (dotted path: materials.concrete.young) and its values; "
                        "several --set make a grid")
    p.add_argument("--jobs", type=int, help="runs at a time (default: the idle cores)")
    p.add_argument("--out", help="the folder of the runs (default <name>_sweep)")
    return p


def parse_seeds(text):
    """'1..4,9' -> [1, 2, 3, 4, 9]; ValueError naming what is wrong."""
    seeds = []
    for part in text.split(","):
        part = part.strip()
        if ".." in part:
            a, b = part.split("..", 1)
            lo, hi = int(a), int(b)
            if hi < lo:
                raise ValueError(f"the range {part!r} runs backwards")
            seeds.extend(range(lo, hi + 1))
        else:
            seeds.append(int(part))
    if any(s < 0 for s in seeds):
        raise ValueError("a seed is an integer ≥ 0")
    if len(set(seeds)) != len(seeds):
        raise ValueError("a seed is given twice")
    return seeds


def parse_set(text):
    """'a.b.c=1,2' -> (('a', 'b', 'c'), [1, 2]) (values read as YAML)."""
    from ruamel.yaml import YAML
    if "=" not in text:
        raise ValueError(f"--set {text!r}: give KEY=V1,V2")
    key, values = text.split("=", 1)
    path = tuple(k for k in key.strip().split("."))
    if not all(path):
        raise ValueError(f"--set {text!r}: an empty key in {key!r}")
    yaml = YAML(typ="safe")
    return path, [yaml.load(v) for v in values.split(",")]


def _voronoi_meshes(data):
    """The mesh mappings of a case's Voronoi meshes (its own, its parts')."""
    out = []
    mesh = data.get("mesh")
    if isinstance(mesh, dict) and mesh.get("kind") == "voronoi":
        out.append(mesh)
    for part in (data.get("parts") or {}).values():
        mesh = part.get("mesh") if isinstance(part, dict) else None
        if isinstance(mesh, dict) and mesh.get("kind") == "voronoi":
            out.append(mesh)
    return out


def variants(text, seeds, sets):
    """[(name, {label: value}, case text)] of every seed and combination of
    the --set values (ruamel's round trip: the comments stay)."""
    from ruamel.yaml import YAML
    grid = list(itertools.product(*[[(path, v) for v in values] for path, values in sets]))
    out = []
    for seed in seeds or [None]:
        for combo in grid:
            yaml = YAML()
            data = yaml.load(text)
            labels = {}
            if seed is not None:
                for mesh in _voronoi_meshes(data):
                    mesh["seed"] = seed
                labels["seed"] = seed
            for path, value in combo:
                node = data
                for k in path[:-1]:
                    node = node[int(k)] if isinstance(node, list) else node[k]
                node[path[-1]] = value
                labels[".".join(path)] = value
            name = "_".join(f"{k.split('.')[-1]}{_short(v)}" for k, v in labels.items())
            data["name"] = f"{data.get('name', 'case')}_{name}"
            buf = io.StringIO()
            yaml.dump(data, buf)
            out.append((name, labels, buf.getvalue()))
    return out


def _short(v):
    return f"{v:g}" if isinstance(v, float) else str(v).replace("/", "_")


def _idle_cores():
    n = os.cpu_count() or 1
    try:
        busy = os.getloadavg()[0]
    except OSError:
        busy = 0.0
    return max(1, n - int(busy + 0.5))


def _summary(values):
    import numpy as np
    v = np.asarray([x for x in values if x is not None], float)
    if v.size == 0:
        return None
    std = float(v.std(ddof=1)) if v.size > 1 else 0.0
    return float(v.mean()), std, float(v.min()), float(v.max())


def main(argv) -> int:
    args = parser().parse_args(argv)
    case_path = Path(args.case)
    try:
        text = case_path.read_text(encoding="utf-8")
    except OSError as exc:
        print(f"rbsm_dyn: sweep: {case_path}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    from ..case import CaseError, load_case_text
    try:
        base = load_case_text(text, str(case_path))
    except CaseError as exc:
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    try:
        seeds = parse_seeds(args.seeds) if args.seeds else []
        sets = [parse_set(s) for s in args.set]
    except ValueError as exc:
        print(f"rbsm_dyn: sweep: --seeds/--set: {exc}", file=sys.stderr)
        return 2
    from ruamel.yaml import YAML
    if not seeds and not sets:
        print("rbsm_dyn: sweep: give --seeds or --set (what varies from run to run)",
              file=sys.stderr)
        return 2
    if seeds and not _voronoi_meshes(YAML().load(text)):
        print("rbsm_dyn: sweep: --seeds: the case has no Voronoi mesh, so a seed changes "
              "nothing", file=sys.stderr)
        return 2
    if args.jobs is not None and args.jobs < 1:
        print(f"rbsm_dyn: sweep: --jobs {args.jobs}: give at least 1", file=sys.stderr)
        return 2
    runs = variants(text, seeds, sets)
    for name, labels, run_text in runs:        # every variant is a valid case
        try:
            load_case_text(run_text, f"{case_path} ({name})")
        except (CaseError, KeyError, IndexError, TypeError) as exc:
            print(f"rbsm_dyn: sweep: --set: {exc}", file=sys.stderr)
            return 2
    out = Path(args.out or f"{base.name}_sweep")
    out.mkdir(parents=True, exist_ok=True)
    jobs = min(args.jobs or _idle_cores(), len(runs))
    probes = list(base.output.probes or {})
    print(f"rbsm_dyn: sweep: {len(runs)} runs of {case_path.name}, {jobs} at a time, "
          f"in {out}/", file=sys.stderr)
    results = _run_all(runs, out, jobs)
    if results is None:
        return 130
    return _report(runs, results, probes, out)


def _run_all(runs, out, jobs):
    """{name: (exit code, wall s)}; None if stopped by Ctrl-C."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    todo = list(runs)
    running = {}
    done = {}
    try:
        while todo or running:
            while todo and len(running) < jobs:
                name, _, run_text = todo.pop(0)
                path = out / f"{name}.yaml"
                path.write_text(run_text, encoding="utf-8")
                log = open(out / f"{name}.log", "w")
                p = subprocess.Popen([sys.executable, "-m", "rbsm_dyn", str(path), "--out",
                                      str(out / f"{name}.h5"), "--quiet", "--threads", "1"],
                                     stdout=log, stderr=subprocess.STDOUT, env=env)
                running[name] = (p, log, time.perf_counter())
            for name, (p, log, t0) in list(running.items()):
                if p.poll() is None:
                    continue
                log.close()
                del running[name]
                done[name] = (p.returncode, time.perf_counter() - t0)
                how = "done" if p.returncode == 0 else f"FAILED (exit {p.returncode}, {name}.log)"
                print(f"rbsm_dyn: sweep: [{len(done)}/{len(runs)}] {name}: {how} in "
                      f"{done[name][1]:.1f} s", file=sys.stderr)
            time.sleep(0.1)
    except KeyboardInterrupt:
        for p, log, _ in running.values():
            p.terminate()
        for p, log, _ in running.values():
            p.wait()
            log.close()
        print("rbsm_dyn: sweep: interrupted; the runs so far are in their folder",
              file=sys.stderr)
        return None
    return done


def _report(runs, results, probes, out):
    import numpy as np
    import rbsm_dyn
    rows = []
    for name, labels, _ in runs:
        code, wall = results[name]
        row = {"run": name, **labels, "exit": code, "wall_s": round(wall, 2)}
        try:        # (a failed run's history holds its path up to the failure)
            h = rbsm_dyn.open_history(out / f"{name}.h5")
        except (OSError, KeyError, ValueError):
            h = None
        if h is not None:
            for pr in probes:
                v = np.asarray(h.observables[pr], float)
                row[f"{pr}_peak"] = float(v[np.argmax(np.abs(v))]) if v.size else None
                row[f"{pr}_last"] = float(v[-1]) if v.size else None
        rows.append(row)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out / "sweep.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(_cell(r.get(k)) for k in keys) + " |")
    print()
    # the scatter over the seeds of each combination of the --set values
    varied = [k for k in keys if k not in ("run", "seed", "exit", "wall_s")
              and not any(k.startswith(f"{pr}_") for pr in probes)]
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in varied), []).append(r)
    head = "".join(f" {k} |" for k in varied)
    print(f"|{head} probe | mean | std | min | max | runs |")
    print("|" + "---|" * (len(varied) + 6))
    for combo, members in groups.items():
        lead = "".join(f" {_cell(v)} |" for v in combo)
        for pr in probes:
            for what in ("peak", "last"):
                vals = [r.get(f"{pr}_{what}") for r in members]
                s = _summary(vals)
                if s is not None:
                    n = sum(v is not None for v in vals)
                    print(f"|{lead} {pr} ({what}) | {s[0]:.6g} | {s[1]:.3g} | {s[2]:.6g} | "
                          f"{s[3]:.6g} | {n} |")
    print(f"\n{out / 'sweep.csv'}")
    return 0 if all(results[n][0] == 0 for n, _, _ in runs) else 1


def _cell(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
