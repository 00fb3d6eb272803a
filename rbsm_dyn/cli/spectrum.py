"""python -m rbsm_dyn spectrum RECORD|RUN.h5 [options]: the response
spectrum of a ground-motion record or of a probe's history
(rbsm_dyn/io/spectrum.py), written as CSV and optionally drawn."""
import argparse
import sys
from pathlib import Path


def parser():
    p = argparse.ArgumentParser(
        prog="python -m rbsm_dyn spectrum",
        description="Response spectrum (relative displacement Sd, pseudo-velocity PSV, "
                    "pseudo-acceleration PSA, absolute acceleration SA) of a record "
                    "(text: time and acceleration columns) or of a probe of a run "
                    "(RUN.h5 --probe NAME), by exact integration of the linearly "
                    "interpolated record (Nigam & Jennings 1969).")
    p.add_argument("source", help="a record (CSV or whitespace columns) or a history RUN.h5")
    p.add_argument("--probe", help="RUN.h5: the probe (displacement or velocity: "
                                   "differentiated to an acceleration)")
    p.add_argument("--dt", type=float, help="a one-column record: its step [s]")
    p.add_argument("--units", default="m/s2", choices=("m/s2", "g"),
                   help="the record's acceleration unit (default m/s2)")
    p.add_argument("--scale", type=float, default=1.0, help="factor on the record")
    p.add_argument("--columns", type=int, nargs=2, default=(0, 1), metavar=("T", "A"),
                   help="the record's time and acceleration columns (default 0 1)")
    p.add_argument("--skip", type=int, default=0, help="header lines to skip")
    p.add_argument("--periods", type=float, nargs="+", metavar="T",
                   help="periods [s] (default: 100 from 0.02 to 5 s, log-spaced)")
    p.add_argument("--damping", type=float, default=0.05,
                   help="damping ratio ζ (default 0.05)")
    p.add_argument("--out", help="the CSV (default SOURCE_spectrum.csv beside the source)")
    p.add_argument("--plot", help="also draw PSA and Sd against the period to this PNG")
    p.add_argument("--quiet", action="store_true")
    return p


def main(argv) -> int:
    args = parser().parse_args(argv)
    import numpy as np
    from ..io import spectrum as sp
    src = Path(args.source)
    if not src.is_file():
        print(f"rbsm_dyn: spectrum: {src}: no such file", file=sys.stderr)
        return 2
    try:
        if src.suffix in (".h5", ".hdf5"):
            if not args.probe:
                print("rbsm_dyn: spectrum: a history needs --probe NAME", file=sys.stderr)
                return 2
            t, a = sp.probe_acceleration(str(src), args.probe)
            a = a * args.scale
        else:
            t, a = sp.read_record(src, dt=args.dt, units=args.units, scale=args.scale,
                                  columns=tuple(args.columns), skip=args.skip)
        periods = (np.geomspace(0.02, 5.0, 100) if args.periods is None
                   else np.asarray(args.periods))
        res = sp.spectrum(t, a, periods, args.damping)
    except (KeyError, ValueError, OSError) as exc:
        print(f"rbsm_dyn: spectrum: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else src.with_name(src.stem + "_spectrum.csv")
    cols = ("period", "Sd", "PSV", "PSA", "SA")
    table = np.column_stack([res[c] for c in cols])
    np.savetxt(out, table, delimiter=",", fmt="%.8g", comments="",
               header=f"# response spectrum of {src.name}"
                      + (f" probe {args.probe}" if args.probe else "")
                      + f", damping {args.damping:g}; period [s], Sd [m], PSV [m/s], "
                        "PSA [m/s2], SA [m/s2]\n" + ",".join(cols))
    if args.plot:
        try:
            _draw(res, args, src, Path(args.plot))
        except ImportError:
            print("rbsm_dyn: spectrum: --plot needs matplotlib: pip install "
                  "'rbsm_dyn[plot]'", file=sys.stderr)
            return 1
    if not args.quiet:
        k = int(np.argmax(res["PSA"]))
        print(f"rbsm_dyn: spectrum at {len(periods)} periods, ζ = {args.damping:g}: "
              f"peak PSA {res['PSA'][k]:.4g} m/s2 at T = {res['period'][k]:.4g} s, "
              f"PGA {np.abs(a).max():.4g} m/s2 -> {out}"
              + (f", {args.plot}" if args.plot else ""))
    return 0


def _draw(res, args, src, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.plot(res["period"], res["PSA"], label="PSA")
    ax1.plot(res["period"], res["SA"], "--", label="SA (absolute)")
    ax1.set_ylabel("acceleration [m/s²]")
    ax1.legend()
    ax2.plot(res["period"], res["Sd"])
    ax2.set_ylabel("Sd, relative displacement [m]")
    for ax in (ax1, ax2):
        ax.set_xscale("log")
        ax.set_xlabel("period [s]")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"{src.name}" + (f" probe {args.probe}" if args.probe else "")
                 + f": response spectrum, ζ = {args.damping:g}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
