"""Copies of a State for the static Newton solvers (solvers/newton.py,
creep.py): what an increment starts again from when it is cut (_save: the
motion and the spring and cell history), and a trial motion undone
(_save_motion: positions and orientations only; _restore puts either
back).  Nothing here imports the other Newton modules.
"""

_SAVED = ("body_pos", "body_quat", "body_rot", "body_dq", "spring_state", "spring_dp",
          "spring_kappa", "spring_dmg", "spring_wp", "spring_wf", "cell_chi", "cell_wf")


def _save_motion(state):
    return {k: getattr(state, k).copy() for k in _SAVED[:4]}


def _save(state):
    return {k: getattr(state, k).copy() for k in _SAVED}


def _restore(state, saved):
    for k, v in saved.items():
        getattr(state, k)[...] = v
