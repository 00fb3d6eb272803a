"""python -m rbsm_dyn check CASE.yaml: read the case, build its model and make
the checks a run would make, without writing anything; say what was built."""
import math

from .prepare import _selections, load, prepare


def main(args, path):
    case = load(path)
    if isinstance(case, int):
        return case
    ready = prepare("check", case, args)
    if isinstance(ready, int):
        return ready
    model, step = ready.model, ready.step
    print(f"{path}: ok ({model.n_bodies} bodies, {model.n_springs} spring points)")
    from ..model.laws import law_notes
    for note in case.material_notes + law_notes(case):
        print(f"  {note}")
    if case.solver.mode == "static":
        how = ("the default for this case" if case.solver._method_default else "given")
        print(f"  solver: static by {case.solver.method} ({how}; docs/case_file.md)")
    if step is not None:
        dt, est = step
        how = ("solver.dt" if case.solver.dt is not None
               else f"× dt_safety {case.solver.dt_safety:g}")
        steps = int(math.ceil(case.solver.end_time / dt - 1e-9))
        print(f"  stable step {est:.4g} s (estimate); dt {dt:.4g} s ({how}), {steps} steps "
              f"to end_time {case.solver.end_time:g} s")
    for line in _selections(case, model):
        print(f"  {line}")
    return 0
