"""Initial velocities and angular velocities of a case (apply_initial)."""
import numpy as np


def apply_initial(case, model, state):
    """Initial velocities and angular velocities (case.initial), in the
    order of the items (a later item overrides an earlier one on the
    bodies they share).  ``{velocity, angular_velocity}``: each cell of the
    group translates at v and spins at ω about its own centroid.
    ``{velocity, rigid: {angular_velocity, center}}``: the group as one
    rigid body, each cell at v + ω × (x_c − center) and spinning at ω
    (center default: the group's centre of mass Σ m_c x_c / Σ m_c)."""
    R = state.body_rot
    for item in case.initial or []:
        ids = model.groups[getattr(item, "group", None) or "all"]
        rigid = getattr(item, "rigid", None)
        v0 = getattr(item, "velocity", None)
        w = getattr(item, "angular_velocity", None)
        if rigid is not None:
            w = np.asarray(rigid.angular_velocity, float)
            x = state.body_pos[ids]
            if rigid.center is not None:
                c = np.asarray(rigid.center, float)
            else:
                m = model.body_mass[ids]
                c = (m[:, None] * x).sum(axis=0) / m.sum()
            v = np.asarray(v0 if v0 is not None else (0.0, 0.0, 0.0), float)
            state.body_vel[ids] = v + np.cross(w, x - c)
        elif v0 is not None:
            state.body_vel[ids] = np.asarray(v0, float)
        if w is not None:
            w = np.asarray(w, float)
            # L = R I Rᵀ ω (world)
            wb = np.einsum("nki,k->ni", R[ids], w)
            state.body_angmom[ids] = np.einsum("nik,nk->ni", R[ids], model.body_inertia[ids] * wb)
