"""``solver``: the mode (dynamic, static, linear, modal) and its keys,
damping and indirect displacement control."""
from __future__ import annotations

import math

import numpy as np
from typing import Annotated, Literal, Optional, Union

from pydantic import Field, PrivateAttr

from .base import _Node, _length


class Rayleigh(_Node):
    """Rayleigh damping α M + β K from a damping ratio ``ratio`` at two
    frequencies ``frequencies`` [Hz] (Chopra, Dynamics of Structures,
    eq. 11.4.9)."""
    ratio: float = Field(gt=0, lt=1)
    frequencies: Annotated[list[float], _length(2, "[f1, f2]")]


class Damping(_Node):
    """Mass-proportional damping ``alpha`` [1/s]; stiffness-proportional
    ``beta`` [s] (a dashpot β k on every intact spring, physics/viscous.py)
    or both from ``rayleigh: {ratio, frequencies}``; Cundall's local
    non-viscous damping ``local`` = β in [0, 1) (the force against each
    body's motion, β × the unbalanced force): set, it makes the run a
    quasi-static explicit one (the kinetic-to-strain energy ratio is
    recorded and checked; docs/case_file.md, "Quasi-static explicit runs")."""
    alpha: float = Field(default=0.0, ge=0)
    beta: float = Field(default=0.0, ge=0)
    rayleigh: Optional[Rayleigh] = None
    local: float = Field(default=0.0, ge=0, lt=1)

    def coefficients(self):
        """(α [1/s], β [s]): the keys' or those of ``rayleigh`` (equal
        ratio ζ at ω1, ω2: α = 2ζ ω1ω2/(ω1 + ω2), β = 2ζ/(ω1 + ω2))."""
        if self.rayleigh is None:
            return float(self.alpha), float(self.beta)
        w1, w2 = (2.0 * math.pi * f for f in self.rayleigh.frequencies)
        z = self.rayleigh.ratio
        return 2.0 * z * w1 * w2 / (w1 + w2), 2.0 * z / (w1 + w2)


class Control(_Node):
    """Indirect displacement control of a static run (solvers/newton.py):
    each increment raises the value of the relative-displacement probe
    ``probe`` by ``increment`` [m] until it reaches ``end`` [m]; the load
    factor follows.  ``stop_fraction`` (optional, in [0, 1)): stop once the
    load has fallen below this fraction of its peak (the softening branch
    followed far enough; the load: the reaction along the prescribed
    displacements, or λ times the loads when there are none)."""
    probe: str
    increment: float = Field(gt=0)
    end: float
    stop_fraction: float = Field(default=0.0, ge=0, lt=1)


#: Largest solver.dt_safety (and fixed solver.dt as a share of the stable
#: step estimate).  The estimate bounds the exact step (0.61-0.74 of it,
#: benchmarks/results/stability.md), and a run with yield keeps its step
#: below the bound of its deformed state, which falls as plastic gaps
#: lengthen the springs' levers (solvers/explicit.py StepAdapter):
#: cases/impulsive_beam.yaml, which diverged at 0.9-0.95 of the undeformed
#: estimate when the step stayed fixed, runs at 1.0 with either yield
#: criterion; every shipped dynamic case ran at 1.0 (the dt sweep in
#: stability.md).  0.95 leaves a margin for what the bound does not see
#: (contacts between any cells have their own check).
DT_SAFETY_MAX = 0.95


class TimeSpan(_Node):
    """Instants of a static run in time, log-spaced: ``increments`` of them
    from ``first`` to ``end`` [s] (``first`` well below the shortest
    relaxation time for a load applied at once)."""
    first: float = Field(gt=0)
    end: float = Field(gt=0)
    increments: int = Field(ge=1)


class Solver(_Node):
    mode: Literal["dynamic", "static", "linear", "modal"]
    method: Literal["relaxation", "newton"] = "relaxation"   # static: default_static_method
    _method_default: bool = PrivateAttr(default=False)      # set by default_static_method
    control: Optional[Control] = None
    time: Optional[Union[TimeSpan, list[float]]] = None
    end_time: Optional[float] = Field(default=None, gt=0)
    dt: Optional[float] = Field(default=None, gt=0)
    dt_safety: float = Field(default=0.8, gt=0, le=DT_SAFETY_MAX)
    damping: Damping = Damping()
    load_steps: int = Field(default=10, ge=1)
    tolerance: float = Field(default=1e-6, gt=0)
    max_iterations: int = Field(default=200000, ge=1)
    relaxation: Literal["adaptive", "local"] = "adaptive"
    damping_factor: float = Field(default=0.7, ge=0, lt=1)
    predictor: bool = True
    damage_update: Literal["auto", "implicit", "implex"] = "auto"

    def instants(self):
        """The instants [s] of a static run in time (``time``), ascending."""
        t = self.time
        if isinstance(t, TimeSpan):
            return [float(x) for x in np.geomspace(t.first, t.end, t.increments)]
        return [float(x) for x in t]
    threads: Optional[int] = Field(default=None, ge=1)
    modes: int = Field(default=6, ge=1)


RELAXATION_KEYS = ("max_iterations", "relaxation", "damping_factor", "predictor")


#: a static case of more bodies than this defaults to dynamic relaxation,
#: which needs no matrix (Newton factorises the assembled stiffness: its
#: fill grows faster than the bodies; the relaxation's linear predictor
#: stops at 5 000 bodies for the same reason)
NEWTON_DEFAULT_MAX_BODIES = 50_000


def continuum_yield(case) -> list:
    """Names of the materials whose yield is judged on the continuum stress
    (`yield.model: continuum`, physics/laws/plastic.py): Newton solves them
    with the cells' plastic strains as unknowns (solvers/newton_plastic.py),
    which indirect control (solver.control) does not offer."""
    return [name for name, m in case.materials.items()
            if m.yield_ is not None and m.yield_.model == "continuum"]


def default_static_method(case, n_bodies=None) -> str:
    """solver.method of a static case that does not give one: `newton`
    (Newton iterations with the consistent tangent: elastic, plastic and
    softening statics, large rotations, frictional contact interfaces;
    issue 30; continuum yield too: solvers/newton_plastic.py), unless the
    case gives keys of the relaxation (RELAXATION_KEYS), or more than
    NEWTON_DEFAULT_MAX_BODIES bodies (``n_bodies``, when known); then
    `relaxation`.  solver.control needs `newton`."""
    s = case.solver
    if s.control is not None or s.time is not None:
        return "newton"
    if any(s.given(k) for k in RELAXATION_KEYS):
        return "relaxation"
    if n_bodies is not None and n_bodies > NEWTON_DEFAULT_MAX_BODIES:
        return "relaxation"
    return "newton"


DYNAMIC_KEYS = ("end_time", "dt", "dt_safety", "damping")
STATIC_KEYS = ("load_steps", "tolerance", "max_iterations", "relaxation",
               "damping_factor", "predictor", "method", "control", "time", "damage_update")
MODAL_KEYS = ("modes",)
