"""python -m rbsm_dyn info CASE.yaml: counts, steps, memory and output size of
the case, without running it."""
from .notice import _run_kind
from .prepare import _extra_observables, _selections, load, prepare

INFO_OMEGA_MAX_BODIES = 5000   # `info` computes the exact ω_max up to this many bodies


def main(args, path):
    case = load(path)
    if isinstance(case, int):
        return case
    ready = prepare("info", case, args)
    if isinstance(ready, int):
        return ready
    return _info(case, ready.model, ready.threads, out=args.restart or args.out)


def _info(case, model, threads, out=None):
    """Counts, steps, memory and output size of the case, without running
    (rbsm_dyn/solvers/estimate.py says how each figure is made).  ``out``: the
    history a run with the same options writes (--restart, --out; default
    output.file)."""
    from ..solvers.estimate import estimate, format_bytes
    from ..solvers.passes import Options
    e = estimate(case, model, extra_observables=_extra_observables(case), threads=threads)
    dt = e.dt_estimate
    plane = (f", plane {case.plane.kind}, thickness {case.plane.thickness:g} m"
             if case.plane is not None else "")
    print(f"case        {case.name} ({case.solver.mode}{plane})")
    print(f"bodies      {e.n_bodies}")
    print(f"springs     {e.n_springs} ({e.n_supports} supports, {model.n_cut} cut)")
    from ..model.laws import law_notes
    for k, note in enumerate(case.material_notes + law_notes(case)):
        print(f"{'materials' if k == 0 else '':<12}{note}")
    for k, line in enumerate(_selections(case, model)):
        print(f"{'selects' if k == 0 else '':<12}{line}")
    print(f"stable dt   {dt:.4g} s (estimate; used × dt_safety {case.solver.dt_safety})")
    if model.n_bodies <= INFO_OMEGA_MAX_BODIES:       # Lanczos: < 1 s at this size
        from ..solvers.modal import omega_max
        w = omega_max(model)
        if w > 0:
            print(f"exact dt    {2.0 / w:.4g} s (2/ω_max, ω_max = {w:.4g} rad/s by Lanczos; "
                  f"estimate/exact = {dt * w / 2.0:.3f})")
    kind = _run_kind(case)
    if kind in ("dynamic", "plane", "relaxation"):
        # the passes of one step, chosen once per run (solvers/passes.py)
        opt = Options.of(model, threads=threads)
        print(f"step        {' -> '.join(opt.passes(kind))} "
              f"({'threaded' if opt.parallel else 'one thread'})")
    if e.steps is not None:
        print(f"steps       {e.steps} (dt = {e.dt:.4g} s to end_time {case.solver.end_time:g} s)")
        print(f"frames      {e.frames} (every {e.out_every} steps)")
        from ..solvers.estimate import format_seconds, wall_seconds
        print(f"wall time   about {format_seconds(wall_seconds(model, e.steps, threads))} "
              f"of stepping on {threads} thread{'s' if threads > 1 else ''} (bench's figures "
              "for a 2-core machine, solvers/estimate.py; a run refuses more than a day "
              "without --force)")
    else:
        print(f"frames      {e.frames}")
    print(f"memory      {format_bytes(e.memory_bytes)} (model {format_bytes(e.model_bytes)}, "
          f"build temporaries {format_bytes(e.build_bytes)}, "
          f"state {format_bytes(e.state_bytes)}, output buffers {format_bytes(e.buffer_bytes)}"
          + (f", stiffness matrix {format_bytes(e.matrix_bytes)}" if e.matrix_bytes else "")
          + ")")
    print(f"output      {format_bytes(e.output_bytes)} -> {out or case.output.file} "
          f"({format_bytes(e.static_bytes)} static + {e.frames} frames of "
          f"{format_bytes(e.frame_bytes)}; fields: {', '.join(case.output.fields) or 'none'})")
    return 0
