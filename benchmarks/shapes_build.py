"""Build cost of a clipped specimen against a box of the same cell count
(issue 12's closing figures): mesh + model build time, peak resident size,
smallest cell volume / mean and the stable step against the box's.

Each shape is built in its own process (the peak resident size is the
process's VmHWM).  The cylinder (axis z, height = diameter) and the box (a
cube) hold the same volume, so one cell size gives the same cell count.

    python benchmarks/shapes_build.py --cells 100000 [--seed 1]

Prints one Markdown row per shape; results in benchmarks/results/shapes_build.md.
"""
import argparse
import json
import math
import subprocess
import sys
import time

CASE = """\
name: shape
units: SI
domain: {domain}
mesh: {{kind: {kind}, size: {size:.6g}, seed: {seed}}}
materials:
  concrete: {{density: 2400, young: 3.0e10, poisson: 0.2}}
boundary: [{{surface: {support}, fix: all}}]
solver: {{mode: dynamic, end_time: 1.0e-4}}
"""


def shapes(cells):
    """Domain texts of equal volume V = 1 m³ and the cell size for `cells`."""
    size = (1.0 / cells) ** (1.0 / 3.0)
    r = (1.0 / (2.0 * math.pi)) ** (1.0 / 3.0)          # π r² · 2r = 1
    return size, {
        "box": ("{box: [[0, 0, 0], [1, 1, 1]]}", "zmin"),
        "cylinder": (f"{{cylinder: {{base: [0, 0, 0], axis: [0, 0, {2 * r:.9g}], "
                     f"radius: {r:.9g}}}}}", "bottom"),
    }


def one(shape, cells, kind, seed):
    """Build in this process; print a JSON line of the figures."""
    from rbsm_dyn.bench import _rss
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model

    size, table = shapes(cells)
    domain, support = table[shape]
    r0 = _rss("VmRSS")
    t0 = time.perf_counter()
    case = load_case_text(CASE.format(domain=domain, kind=kind, size=size, seed=seed,
                                      support=support), f"{shape}.yaml")
    model = build_model(case)
    t_build = time.perf_counter() - t0
    v = model.body_volume[:model.n_bodies] if hasattr(model, "body_volume") else None
    out = {"shape": shape, "bodies": int(model.n_bodies), "springs": int(model.n_springs),
           "build_s": t_build, "peak_mib": _rss("VmHWM"), "before_mib": r0,
           "stable_dt": float(model.stable_dt())}
    if v is not None:
        out.update(vmin_ratio=float(v.min() / v.mean()))
    print(json.dumps(out))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cells", type=float, default=1e5)
    p.add_argument("--kind", default="voronoi")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--one", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    cells = int(a.cells)
    if a.one:
        return one(a.one, cells, a.kind, a.seed)
    rows = {}
    for shape in ("box", "cylinder"):
        r = subprocess.run([sys.executable, __file__, "--cells", str(cells), "--kind", a.kind,
                            "--seed", str(a.seed), "--one", shape],
                           capture_output=True, text=True, check=False)
        if r.returncode:
            sys.exit(f"{shape}: {r.stderr.strip()}")
        rows[shape] = json.loads(r.stdout.strip().splitlines()[-1])
        print(rows[shape], flush=True)
    box = rows["box"]
    print(f"\n| shape | bodies | spring points | build [s] | build [µs/body] | peak [MiB] | "
          f"smallest cell / mean | stable step / box's |")
    print("|---|---|---|---|---|---|---|---|")
    for shape, r in rows.items():
        print(f"| {shape} | {r['bodies']} | {r['springs']} | {r['build_s']:.1f} | "
              f"{r['build_s'] / r['bodies'] * 1e6:.0f} | {r['peak_mib']:.0f} | "
              f"{r.get('vmin_ratio', float('nan')):.3f} | {r['stable_dt'] / box['stable_dt']:.3f} |")


if __name__ == "__main__":
    main()
