"""Shipped contact cases killed at random moments and restarted (issue 30:
"a contact case (impact_plate, masonry_arch) killed at 20 random moments
restarts to a bitwise-equal history").

    python benchmarks/restart_cases.py                         # both cases, 20 kills each, ~8 min
    python benchmarks/restart_cases.py --cases impact_plate --kills 5 --out -
    python benchmarks/restart_cases.py --end-time masonry_arch=0.8   # a shortened copy

For each case (cases/impact_plate.yaml, cases/masonry_arch.yaml) a copy is
made in a temporary folder (never run inside cases/: a run writes its model
cache, .rbsm_cache/, beside the case), with two keys added, both of them
keys a restart may change (solvers/checkpoint.py FREE_KEYS), neither of
them touching the physics:

* ``output.checkpoint_interval`` = ``--checkpoint-frames`` (10) output
  intervals: a checkpoint every 10 frames (impact_plate 16 in its run,
  masonry_arch 32), so that most kills land between two of them;
* ``output.flush_interval: 0``: every frame on disk at once (not in
  batches up to 1 s late), so that the kill moments can be placed by the
  frames the file holds, whatever the machine's speed at the time.

``solver.end_time`` is the shipped one: both cases run in well under 60 s
on one thread (impact_plate ~3 s, masonry_arch ~8-14 s), so neither is
shortened (``--end-time CASE=T`` would shorten a copy; the report says so).

1. a short warm-up run (``--max-steps 20``: Numba cache and model cache
   loaded or made, not timed), then the **reference**: ``python -m rbsm_dyn
   CASE --out reference.h5`` uninterrupted: F frames, its wall time from
   its first frame (the output file appears when the run appends it) to
   its end T.
2. ``--kills`` (20) runs of ``python -m rbsm_dyn CASE --out killI.h5``,
   one at a time, each killed with SIGKILL at a moment drawn from a seeded
   generator (``--seed``), stratified over the run: kill i waits until the
   file holds frame floor((i + U) F / K) (U uniform in [0, 1)), then a
   further uniform share of one frame's wall time (T / F), so kill 0 falls
   in the first frames (before the first checkpoint), the last one in the
   last 1/K of the run (it may end before the kill), the others between,
   anywhere in the step (computing, writing a frame or a checkpoint).
3. each killed run is continued with ``python -m rbsm_dyn CASE --restart
   killI.h5``.  A run killed before its first checkpoint is refused with
   exit 2 (checked) and run again from the start with ``--out``; a run that
   ended before its kill is compared as it is.
4. **comparison** with the reference: every dataset of the HDF5 file (the
   frames, observables and probes, the static model data, /parameters, and
   both /checkpoint slots: the final State and contact state, and the
   previous checkpoint) compared bitwise -- same dtype, shape and bytes
   (np.array_equal for string datasets) -- and every attribute of every
   group and dataset (root ``frames`` and ``status``, checkpoint
   ``current``, units ...) with np.array_equal.  Any that differ are named.

Prints a Markdown table (case, kills, restarts bitwise equal, datasets
compared, wall time) and one row per kill, and writes them to --out
(default benchmarks/results/restart_cases.md) with the date, the git
revision and the command line.  Exit 1 when some restarted history differs.

Run it with one Numba thread (NUMBA_NUM_THREADS=1, the default here): the
runs are made one at a time, this process only polls the output file's
frame count meanwhile.

Found with it (2026-11-27): a run killed after its end-of-run checkpoint
but before it set ``status`` "completed" restarted to the same frames and
final state, but wrote that checkpoint again into the other slot, where an
uninterrupted run keeps the previous checkpoint, and flipped
``/checkpoint`` ``current``; fixed in solvers/explicit.py ``run`` (a
restart with no step left writes no checkpoint), test in
tests/test_restart_contact.py.
"""
import argparse
import datetime
import os
import platform
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CASES = ("impact_plate", "masonry_arch")
WAIT = 600.0            # s: give up on a run that shows no progress
POLL = 0.005            # s between looks at the output file (an HDF5 open: little CPU)


# ------------------------------------------------------------------ the case copy

def case_copy(name, folder, checkpoint_frames, end_time=None):
    """cases/NAME.yaml copied into ``folder`` with output.checkpoint_interval
    (and solver.end_time when given) set; returns (path, interval, end_time)."""
    import yaml
    text = (ROOT / "cases" / f"{name}.yaml").read_text(encoding="utf-8")
    data = yaml.safe_load(text)
    interval = float(data["output"]["interval"])
    every = checkpoint_frames * interval
    lines = text.splitlines()
    out = []
    done = {"checkpoint": False, "end": end_time is None}
    for line in lines:
        if end_time is not None and line.startswith("solver:"):
            # the solver mapping on one line (both cases): end_time replaced
            import re
            new = re.sub(r"end_time:\s*[^,}]+", f"end_time: {end_time!r}", line)
            if new == line:
                raise SystemExit(f"{name}: cannot set solver.end_time in {line!r}")
            line, done["end"] = new, True
        out.append(line)
        if line.rstrip() == "output:":
            out.append(f"  checkpoint_interval: {every!r}   # benchmarks/restart_cases.py")
            out.append("  flush_interval: 0                 # every frame on disk at once")
            done["checkpoint"] = True
    if not all(done.values()):
        raise SystemExit(f"{name}: the copy could not be edited ({done})")
    path = folder / f"{name}.yaml"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    check = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert check["output"]["checkpoint_interval"] == every
    assert check["output"]["flush_interval"] == 0
    return path, every, float(check["solver"]["end_time"])


# ------------------------------------------------------------------ runs

def _env():
    env = dict(os.environ)
    env.setdefault("NUMBA_NUM_THREADS", "1")
    env.pop("RBSM_PROGRESS", None)
    return env


def spawn(case, *args, log):
    return subprocess.Popen([sys.executable, "-m", "rbsm_dyn", str(case), *map(str, args),
                             "--quiet"], env=_env(), cwd=str(case.parent),
                            stdout=log, stderr=subprocess.STDOUT)


def run(case, *args, log):
    """(exit code, wall [s]) of one whole run."""
    t0 = time.perf_counter()
    proc = spawn(case, *args, log=log)
    try:
        proc.wait(timeout=WAIT * 10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        raise
    return proc.returncode, time.perf_counter() - t0


def wait_first_frame(proc, out):
    """Poll until ``out`` exists (the run appended its first frame: the
    staged file takes its name then) or the run ends; the monotonic time."""
    t0 = time.monotonic()
    while not out.exists():
        if proc.poll() is not None:
            break
        if time.monotonic() - t0 > WAIT:
            proc.kill()
            proc.wait()
            raise SystemExit(f"{out}: no first frame after {WAIT:g} s")
        time.sleep(POLL)
    return time.monotonic()


def frames_on_disk(out):
    """The root attribute ``frames`` of a file being written (0 before it
    exists or while it cannot be read)."""
    try:
        with h5py.File(str(out), "r", swmr=True) as f:
            return int(f.attrs["frames"])
    except (OSError, KeyError):
        return 0


def reference(case, folder, log):
    """Warm-up, then the uninterrupted run: (path, process wall, loop wall T)."""
    warm = folder / "warmup.h5"
    code, _ = run(case, "--out", warm, "--max-steps", 20, log=log)
    if code != 0:
        raise SystemExit(f"{case}: warm-up run exit {code} (log {log.name})")
    warm.unlink()
    ref = folder / "reference.h5"
    t0 = time.monotonic()
    proc = spawn(case, "--out", ref, log=log)
    t_first = wait_first_frame(proc, ref)
    proc.wait(timeout=WAIT * 10)
    t_end = time.monotonic()
    if proc.returncode != 0:
        raise SystemExit(f"{case}: reference run exit {proc.returncode} (log {log.name})")
    return ref, t_end - t0, t_end - t_first


def kill_run(case, out, frame, delay, log):
    """Run the case into ``out`` and SIGKILL it ``delay`` s after its file
    holds ``frame`` frames (0: after its first frame appears); returns
    dict(ended_first, at: s after the first frame, code)."""
    proc = spawn(case, "--out", out, log=log)
    t_first = wait_first_frame(proc, out)
    t0 = time.monotonic()
    while frame > 0 and proc.poll() is None and frames_on_disk(out) < frame:
        if time.monotonic() - t0 > WAIT:
            proc.kill()
            proc.wait()
            raise SystemExit(f"{out}: not {frame} frames after {WAIT:g} s")
        time.sleep(POLL)
    due = time.monotonic() + delay
    while time.monotonic() < due and proc.poll() is None:
        time.sleep(POLL)
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        return dict(ended_first=False, at=time.monotonic() - t_first, code=proc.returncode)
    return dict(ended_first=True, at=time.monotonic() - t_first, code=proc.returncode)


def left_in_file(out):
    """(frames on disk, status, checkpoint (step, time, frames) or None)."""
    from rbsm_dyn.io.history import _open_h5
    from rbsm_dyn.solvers.checkpoint import checkpoint_info
    with _open_h5(str(out)) as f:
        frames, status = int(f.attrs.get("frames", 0)), str(f.attrs.get("status", ""))
    return frames, status, checkpoint_info(out)


# ------------------------------------------------------------------ comparison

def _items(f):
    out = {"/": f}
    f.visititems(lambda name, obj: out.__setitem__(name, obj))
    return out


def _same_value(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind in "OSUV":
        return bool(np.array_equal(a, b))
    return np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes()


def compare(path, ref):
    """(datasets compared, attributes compared, list of differences) of two
    history files: every dataset bitwise, every attribute."""
    diffs = []
    n_ds = n_attr = 0
    with h5py.File(str(path), "r") as fa, h5py.File(str(ref), "r") as fb:
        a, b = _items(fa), _items(fb)
        for name in sorted(set(a) | set(b)):
            if name not in a or name not in b:
                diffs.append(f"{name}: only in {'the reference' if name in b else 'the run'}")
                continue
            oa, ob = a[name], b[name]
            if isinstance(oa, h5py.Dataset) != isinstance(ob, h5py.Dataset):
                diffs.append(f"{name}: a dataset in one file, a group in the other")
                continue
            if isinstance(oa, h5py.Dataset):
                n_ds += 1
                va, vb = oa[()], ob[()]
                if not _same_value(va, vb):
                    va, vb = np.asarray(va), np.asarray(vb)
                    how = (f"shape {va.shape} {va.dtype} vs {vb.shape} {vb.dtype}"
                           if va.shape != vb.shape or va.dtype != vb.dtype else
                           f"{int(np.sum(va != vb))} of {va.size} values differ"
                           if va.dtype.kind not in "OSUV" else "values differ")
                    diffs.append(f"{name}: {how}")
            for k in sorted(set(oa.attrs) | set(ob.attrs)):
                n_attr += 1
                if k not in oa.attrs or k not in ob.attrs:
                    diffs.append(f"{name} attribute {k}: only in one file")
                elif not _same_value(oa.attrs[k], ob.attrs[k]):
                    diffs.append(f"{name} attribute {k}: {oa.attrs[k]!r} vs {ob.attrs[k]!r}")
    return n_ds, n_attr, diffs


# ------------------------------------------------------------------ one case

def one_case(name, args, work, rng):
    folder = work / name
    folder.mkdir(parents=True)
    end_time = args.end_time.get(name)
    case, every, end = case_copy(name, folder, args.checkpoint_frames, end_time)
    log = open(folder / "runs.log", "w")
    t_case = time.perf_counter()
    ref, ref_wall, loop = reference(case, folder, log)
    ref_frames, _, ref_ck = left_in_file(ref)
    print(f"{name}: reference {ref_wall:.1f} s (loop {loop:.1f} s), {ref_frames} frames, "
          f"end step {ref_ck[0]}", flush=True)
    if ref_wall > 60.0 and end_time is None:
        print(f"{name}: the reference took {ref_wall:.0f} s, more than 60 s: consider "
              f"--end-time {name}=T (a shorter copy)", flush=True)
    k = args.kills
    # stratified over the run's frames: kill i waits for frame
    # floor((i + U) F / K), then up to one frame's wall time more
    u = (np.arange(k) + rng.uniform(0.0, 1.0, k)) / k
    target = np.floor(u * ref_frames).astype(int)
    delay = rng.uniform(0.0, 1.0, k) * loop / ref_frames
    rows = []
    for i in range(k):
        out = folder / f"kill{i}.h5"
        killed = kill_run(case, out, int(target[i]), float(delay[i]), log)
        frames, status, ck = left_in_file(out)
        row = dict(i=i, u=u[i], target=int(target[i]), delay=float(delay[i]), at=killed["at"],
                   frames=frames, ck=ck, ended_first=killed["ended_first"])
        t0 = time.perf_counter()
        if killed["ended_first"]:
            if killed["code"] != 0 or status != "completed":
                raise SystemExit(f"{name} kill {i}: the run ended by itself with exit "
                                 f"{killed['code']}, status {status!r}")
            row["what"] = "ended before the kill"
        elif ck is None:
            code, _ = run(case, "--restart", out, log=log)
            if code != 2:
                raise SystemExit(f"{name} kill {i}: --restart without a checkpoint gave exit "
                                 f"{code}, not 2 (log {log.name})")
            code, _ = run(case, "--out", out, log=log)
            if code != 0:
                raise SystemExit(f"{name} kill {i}: the new run exit {code}")
            row["what"] = "no checkpoint yet: refused (exit 2), run again"
        else:
            code, _ = run(case, "--restart", out, log=log)
            if code != 0:
                raise SystemExit(f"{name} kill {i}: --restart exit {code} (log {log.name})")
            row["what"] = "restarted"
        row["wall"] = time.perf_counter() - t0
        row["n_ds"], row["n_attr"], row["diffs"] = compare(out, ref)
        rows.append(row)
        same = "bitwise equal" if not row["diffs"] else \
            f"DIFFERS: {'; '.join(row['diffs'][:6])}"
        ckt = "none" if ck is None else f"step {ck[0]} (t = {ck[1]:.4g} s, {ck[2]} frames)"
        print(f"  kill {i}: frame {row['target']} + {1e3 * row['delay']:.1f} ms "
              f"({row['at']:.3f} s after the first frame), {frames} frames on disk, "
              f"checkpoint {ckt}; {row['what']} ({row['wall']:.1f} s): {same}", flush=True)
        if not args.keep:
            out.unlink()
    log.close()
    wall = time.perf_counter() - t_case
    restarted = [r for r in rows if r["what"] == "restarted"]
    summary = dict(name=name, kills=k, restarted=len(restarted),
                   restarted_equal=sum(not r["diffs"] for r in restarted),
                   others=len(rows) - len(restarted),
                   others_equal=sum(not r["diffs"] for r in rows if r["what"] != "restarted"),
                   n_ds=rows[0]["n_ds"] if rows else 0,
                   n_ds_total=sum(r["n_ds"] for r in rows),
                   n_attr=rows[0]["n_attr"] if rows else 0,
                   wall=wall, ref_wall=ref_wall, loop=loop, frames=ref_frames,
                   steps=ref_ck[0], every=every, end=end, shortened=end_time is not None,
                   rows=rows)
    return summary


# ------------------------------------------------------------------ report

def report(results, args, argv):
    import rbsm_dyn
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                         capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                           capture_output=True, text=True).stdout.strip()
    code = Path(rbsm_dyn.__file__).resolve().parent
    import numba
    lines = ["# Contact cases killed at random moments and restarted "
             "(benchmarks/restart_cases.py, issue 30)", "",
             f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, git {rev}"
             f"{' (working tree with changes)' if dirty else ''}, "
             f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"NUMBA_NUM_THREADS={_env()['NUMBA_NUM_THREADS']}, Python "
             f"{platform.python_version()}, NumPy {np.__version__}, Numba {numba.__version__}, "
             f"h5py {h5py.__version__}; code from `{code}`.", "",
             "Command: `" + " ".join(shlex.quote(a) for a in
                                     ["python", "benchmarks/restart_cases.py", *argv]) + "`", "",
             "| case | kills | restarts bitwise equal | other runs equal (no checkpoint yet "
             "/ ended before the kill) | datasets compared, all files (per file; attributes "
             "per file) | wall time |",
             "|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r['name']} | {r['kills']} | {r['restarted_equal']}/{r['restarted']} | "
                     f"{r['others_equal']}/{r['others']} | {r['n_ds_total']} ({r['n_ds']}; "
                     f"{r['n_attr']}) | {r['wall']:.0f} s |")
    lines += ["", "Wall time: the whole case (warm-up, reference, the killed runs, the "
              "restarts or new runs, the comparisons), one run at a time, nice 19, "
              "on a shared host.", ""]
    for r in results:
        lines += [f"## {r['name']}", "",
                  f"cases/{r['name']}.yaml copied with output.checkpoint_interval = "
                  f"{r['every']:g} s ({args.checkpoint_frames} frames); solver.end_time "
                  + (f"**shortened to {r['end']:g} s** (--end-time)" if r["shortened"]
                     else f"{r['end']:g} s as shipped (not shortened)")
                  + f".  Reference: {r['steps']} steps, {r['frames']} frames, "
                  f"{r['ref_wall']:.1f} s process wall time, of which {r['loop']:.1f} s "
                  "from its first frame to its end (so one frame's wall time is about "
                  f"{1e3 * r['loop'] / r['frames']:.0f} ms).", "",
                  "| kill | killed at (frame + delay) | after the first frame | frames on disk "
                  "| last checkpoint | then | wall | result |",
                  "|---|---|---|---|---|---|---|---|"]
        for w in r["rows"]:
            ck = "none" if w["ck"] is None else \
                f"step {w['ck'][0]}, t = {w['ck'][1]:.4g} s, {w['ck'][2]} frames"
            res = "bitwise equal" if not w["diffs"] else \
                "**differs**: " + "; ".join(w["diffs"][:8]) + \
                (f" (and {len(w['diffs']) - 8} more)" if len(w["diffs"]) > 8 else "")
            lines.append(f"| {w['i']} | {w['target']} + {1e3 * w['delay']:.1f} ms | "
                         f"{w['at']:.3f} s | {w['frames']} | {ck} | "
                         f"{w['what']} | {w['wall']:.1f} s | {res} |")
        lines.append("")
    return "\n".join(lines) + "\n"


def _end_times(text):
    out = {}
    for item in filter(None, (text or "").split(",")):
        k, _, v = item.partition("=")
        out[k.strip()] = float(v)
    return out


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", default=",".join(CASES))
    p.add_argument("--kills", type=int, default=20)
    p.add_argument("--seed", type=int, default=30)
    p.add_argument("--checkpoint-frames", type=int, default=10,
                   help="output.checkpoint_interval in output intervals (default 10)")
    p.add_argument("--end-time", type=_end_times, default={},
                   help="CASE=T[,CASE=T]: shorten solver.end_time in the copy")
    p.add_argument("--out", default=str(HERE / "results" / "restart_cases.md"),
                   help="Markdown report ('-': print only)")
    p.add_argument("--work", default=None, help="folder for the runs (default: a temp dir, "
                   "removed at the end)")
    p.add_argument("--keep", action="store_true", help="keep the histories")
    args = p.parse_args(argv)
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="restart_cases_"))
    work.mkdir(parents=True, exist_ok=True)
    results = []
    try:
        for name in filter(None, args.cases.split(",")):
            # each case its own generator: its kill moments do not depend on
            # which cases run before it
            rng = np.random.default_rng([args.seed, zlib.crc32(name.encode())])
            results.append(one_case(name, args, work, rng))
    finally:
        if not args.keep and not args.work:
            shutil.rmtree(work, ignore_errors=True)
    text = report(results, args, argv)
    print(text)
    if args.out != "-":
        Path(args.out).write_text(text, encoding="utf-8")
    bad = sum(len(r["rows"]) - r["restarted_equal"] - r["others_equal"] for r in results)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
