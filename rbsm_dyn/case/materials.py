"""``materials``: each material's elastic constants, its ``yield``
criterion and its ``rupture``."""
from __future__ import annotations

from typing import Annotated, Literal, Optional

from pydantic import Field

from .base import _Node, _length


class Yield(_Node):
    """Yield criterion of the springs (physics/laws/plastic.py): the
    traction of each spring point returned to the surface of ``criterion``
    with ``stress`` (normal, tresca, von_mises) or ``cohesion``,
    ``friction_angle`` [degrees] and ``tension`` (mohr_coulomb).
    ``model``: ``interface`` (default: the spring's traction alone decides)
    or ``continuum`` (tresca, von_mises, blocks and Voronoi cells: each
    cell's stress returned to J2's cylinder, its plastic strain moving its
    springs' gaps; pressure-free)."""
    criterion: Literal["normal", "tresca", "von_mises", "mohr_coulomb"]
    stress: Optional[float] = Field(default=None, gt=0)
    cohesion: Optional[float] = Field(default=None, ge=0)
    friction_angle: Optional[float] = Field(default=None, ge=0, lt=90)  # degrees
    tension: Optional[float] = Field(default=None, ge=0)
    model: Optional[Literal["interface", "continuum"]] = None


class Cap(_Node):
    """The compressive cap of a spring's normal traction
    (physics/laws/rupture.py cap_stress): pore collapse at ``stress``
    σ_c0 [Pa], hardening H_c0 = ``hardening`` × E0 up to ``transition`` ×
    σ_c0/E0 of normal strain, densification beyond (LDPM's compressive
    boundary, Cusatis et al. 2011; the defaults, and σ_c0 = 150 MPa, are
    those of Chrono's LDPM test material)."""
    stress: float = Field(gt=0)
    hardening: float = Field(default=0.4, ge=0)
    transition: float = Field(default=4.0, ge=1)


class Rupture(_Node):
    """``{strain}`` or ``{fracture_energy, tensile_strength}`` (+ ``law``,
    ``shear_strength``, ``compressive_strength``, ``shear_fracture_energy``,
    ``values``, ``rate``, ``cap``)."""
    strain: Optional[float] = Field(default=None, gt=0)
    fracture_energy: Optional[float] = Field(default=None, gt=0)
    tensile_strength: Optional[float] = Field(default=None, gt=0)
    law: Optional[Literal["mixed_mode", "tension"]] = None
    shear_strength: Optional[float] = Field(default=None, gt=0)
    compressive_strength: Optional[float] = Field(default=None, gt=0)
    shear_fracture_energy: Optional[float] = Field(default=None, gt=0)
    values: Literal["material", "spring"] = "material"
    rate: Optional[Literal["fib2010"]] = None
    cap: Optional[Cap] = None


class Viscoelastic(_Node):
    """Time in the springs (physics/viscous.py); ``young`` is the
    instantaneous modulus E.  ``kind``: ``kelvin`` (σ = E (ε + τ ε̇), the
    retardation time ``tau`` [s]), ``maxwell`` (E(t) = E e^(−t/τ)),
    ``standard`` (the standard linear solid: E(t) = E∞ + (E − E∞) e^(−t/τ),
    ``relaxed`` = E∞ [Pa]) or ``prony`` (E(t) = E − Σ E_i (1 − e^(−t/τ_i)),
    ``terms`` [[E_i, τ_i], ...] in [Pa, s], E∞ = E − Σ E_i ≥ 0)."""
    kind: Literal["kelvin", "maxwell", "standard", "prony"]
    tau: Optional[float] = Field(default=None, gt=0)
    relaxed: Optional[float] = Field(default=None, ge=0)
    terms: Optional[list[Annotated[list[float], _length(2, "[E_i, tau_i]")]]] = None


class Material(_Node):
    """Elastic constants, yield and rupture; ``model: concrete`` with ``fc``
    (the mean cylinder compressive strength f_cm) fills in those not given
    from the fib Model Code 2010, ``model: rock`` with ``ucs`` (σ_ci) and
    ``rock`` (or ``mi`` and ``modulus_ratio``) from the Hoek–Brown
    criterion and published ratios, ``model: brick`` with ``fb`` (a
    masonry unit's compressive strength) and ``model: mortar`` with ``fm``
    (a mortar joint's, for a bonded interface's ``material``) from masonry
    relations and typical values (case/presets.py)."""
    density: float = Field(gt=0)
    young: float = Field(gt=0)
    poisson: float = Field(ge=0, lt=0.5)
    model: Optional[Literal["concrete", "rock", "brick", "mortar"]] = None
    fc: Optional[float] = Field(default=None, gt=0)
    ucs: Optional[float] = Field(default=None, gt=0)
    fb: Optional[float] = Field(default=None, gt=0)   # model: brick, the unit's f_b
    fm: Optional[float] = Field(default=None, gt=0)   # model: mortar, the mortar's f_m
    rock: Optional[str] = None
    mi: Optional[float] = Field(default=None, gt=0)
    modulus_ratio: Optional[float] = Field(default=None, gt=0)
    stiffness: Literal["calibrated", "kawai", "homogeneous"] = "calibrated"
    yield_: Optional[Yield] = Field(default=None, alias="yield")
    rupture: Optional[Rupture] = None
    friction: Optional[float] = Field(default=None, ge=0)
    viscoelastic: Optional[Viscoelastic] = None
