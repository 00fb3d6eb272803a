"""Yade side of benchmarks/peer_yade.py: the VERIFICATION D1 bar wave as
bonded spheres (run under Yade, not plain Python).

    OMP_NUM_THREADS=1 yade -n -x -j1 benchmarks/peer_yade_bar.py PARAMS.json OUT.json

PARAMS.json: {"k": cells across the 20 mm section, "repeat": timed runs,
"budget": seconds after which no further timed run starts, "dt": null (use
Yade's GlobalStiffnessTimeStepper) or a step in s}.  Writes OUT.json with
bodies, interactions, dt, steps, loop wall times and the probe histories.

Model (matched to the rbsm_dyn block lattice of the same bar, see
peer_yade.py): a simple cubic lattice of spheres of radius R = h/2, centres
at the block centroids ((i+1/2)h, (j+1/2)h, (l+1/2)h), cohesive bonds
between the 6 nearest neighbours (CohFrictMat, Ip2_CohFrictMat_CohFrictMat_
CohFrictPhys, Law2_ScGeom6D_CohFrictPhys_CohesionMoment), no damping
(NewtonIntegrator damping = 0; Yade's default is 0.2), no gravity.
"""
import json
import math
import sys
import time

from yade import O
from yade.utils import sphere
from yade.wrapper import (Bo1_Sphere_Aabb, CohFrictMat, ForceResetter,
                          GlobalStiffnessTimeStepper, Ig2_Sphere_Sphere_ScGeom6D,
                          InsertionSortCollider, InteractionLoop,
                          Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                          Law2_ScGeom6D_CohFrictPhys_CohesionMoment, NewtonIntegrator,
                          PyRunner)

params = json.load(open(sys.argv[1]))
OUT = sys.argv[2]

# the case (cases/bar_wave.yaml, VERIFICATION D1): steel bar 1 m x 20 x 20 mm,
# E = 200 GPa, rho = 8000 kg/m3, nu = 0; first layer pushed at v = 1 m/s in x;
# end time 1.6e-4 s
E, RHO, L, B, V, END = 200.0e9, 8000.0, 1.0, 0.02, 1.0, 1.6e-4
k = int(params["k"])
h = B / k                      # lattice spacing = block size of rbsm_dyn
R = h / 2.0
nx = int(round(L / h))

# Stiffness (Yade source, pkg/dem/CohesiveFrictionalContactLaw.cpp,
# Ip2_CohFrictMat_CohFrictMat_CohFrictPhys::go): kn = 2 Ea Ra Eb Rb/(Ea Ra + Eb Rb)
# = E_p R for equal spheres; ks = poisson * kn (Yade's "poisson" is ks/kn);
# kr = R1 R2 ks alphaKr; ktw = R1 R2 ks alphaKtw.
# Targets, the rbsm_dyn face between two h-cubes (DESIGN.md §1, k_n = E/h,
# k_s = alpha E/h per unit area, alpha = 1 at nu = 0, VERIFICATION "General"):
#   normal  Kn  = (E/h) h^2           = E h       -> E_p = Kn/R = 2 E
#   shear   Ks  = (E/h) h^2           = E h       -> poisson (ks/kn) = 1
#   bending Kr  = (E/h) I, I = h^4/12 = E h^3/12  -> alphaKr  = Kr/(R^2 Ks) = 1/3
#   twist   Ktw = (E/h) J, J = h^4/6  = E h^3/6   -> alphaKtw = Ktw/(R^2 Ks) = 2/3
# Macroscopic modulus of the simple cubic lattice (stress kn d/(2R)^2 at strain
# d/(2R)): E_macro = kn/(2R) = E_p/2 = E.
# Density: one sphere per cube of side 2R, so rho_p (4/3) pi R^3 = rho (2R)^3,
# rho_p = 6 rho/pi (mass per body = rho h^3, as the rbsm_dyn block).
# Rotational inertia: set to the cube's m h^2/6 (rbsm_dyn block) instead of the
# sphere's 2/5 m R^2, so the two discrete systems are the same (small rotations).
E_P = 2.0 * E
RHO_P = 6.0 * RHO / math.pi
COH = 1.0e30                   # bonds never break (elastic problem)


def build(dt=None):
    """Scene at t = 0: lattice, bonds made in one step at zero velocity (no
    force: centres exactly 2R apart), then the driver gets its velocity."""
    O.reset()
    mat = O.materials.append(CohFrictMat(
        young=E_P, poisson=1.0, density=RHO_P, frictionAngle=0.5, isCohesive=True,
        normalCohesion=COH, shearCohesion=COH, momentRotationLaw=True,
        alphaKr=1.0 / 3.0, alphaKtw=2.0 / 3.0, etaRoll=-1.0, etaTwist=-1.0))
    layer = {}
    inertia = RHO * h ** 3 * h ** 2 / 6.0
    for i in range(nx):
        for j in range(k):
            for l in range(k):
                b = sphere(((i + 0.5) * h, (j + 0.5) * h, (l + 0.5) * h), R, material=mat)
                b.state.inertia = (inertia, inertia, inertia)
                layer.setdefault(i, []).append(O.bodies.append(b))
    collider = InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=1.2)])
    ig2 = Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=1.2)
    stepper = GlobalStiffnessTimeStepper(timestepSafetyCoefficient=0.8, timeStepUpdateInterval=1)
    O.engines = [ForceResetter(), collider,
                 InteractionLoop([ig2], [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True)],
                                 [Law2_ScGeom6D_CohFrictPhys_CohesionMoment()]),
                 stepper, NewtonIntegrator(damping=0.0)]
    O.dt = 1.0e-12
    O.step()                   # bonds, stiffnesses, Yade's stable step
    collider.boundDispatcher.functors[0].aabbEnlargeFactor = -1.0
    ig2.interactionDetectionFactor = -1.0
    O.engines = [e for e in O.engines if e is not stepper]
    if dt is not None:
        O.dt = dt
    for i in layer[0]:         # driver: first layer, x velocity prescribed
        O.bodies[i].state.blockedDOFs = "x"
        O.bodies[i].state.vel = (V, 0.0, 0.0)
    return layer


layer = build(params.get("dt"))
dt = O.dt
n_steps = int(math.ceil(END / dt - 1e-9))
n_bodies = len(O.bodies)
n_inter = sum(1 for i in O.interactions if i.isReal)
mid_layer = nx // 2            # centroid at 0.5 + h/2, driver at h/2: distance 0.5 m

# ---- timed runs: the time loop only, stamped from inside the simulation
# thread (a PyRunner at the end of the step list, at the end of the first step
# and n_steps later); O.run(n, True) alone adds tens of ms of polling.
stamps = []


def stamp():
    stamps.append((time.perf_counter(), time.process_time()))


loops, cpus = [], []
spent = 0.0
for r in range(int(params["repeat"])):
    if r > 0:
        if spent > params["budget"]:
            break
        build(dt)
    stamps.clear()
    O.engines = O.engines + [PyRunner(command="stamp()", iterPeriod=n_steps, initRun=True, nDo=2)]
    O.run(n_steps + 1, True)
    loops.append(stamps[1][0] - stamps[0][0])
    cpus.append(stamps[1][1] - stamps[0][1])
    spent += loops[-1]

# ---- probe run (not timed): mean x velocity of the mid layer and the force
# of the driver layer on the bar, every step.  After step n the stored
# velocity is v(n - 1/2) (leapfrog), the forces are those at x(n - 1), t(n - 1).
# O.iter counts up only after the whole step list (Scene::moveToNextTimeStep):
# inside step n (n = 1 the first after the build), O.iter = it0 + n - 1.
build(dt)
mid = layer[mid_layer]
drv = layer[0]
probe = {"t_vel": [], "mid_vx": [], "t_force": [], "driver_fx": []}
it0 = O.iter


def record():
    n = O.iter - it0 + 1
    probe["t_vel"].append((n - 0.5) * dt)
    probe["mid_vx"].append(sum(O.bodies[i].state.vel[0] for i in mid) / len(mid))
    probe["t_force"].append((n - 1) * dt)
    # reaction of the prescribed motion = minus the bond forces on the driver
    probe["driver_fx"].append(-sum(O.forces.f(i)[0] for i in drv))


O.engines = O.engines + [PyRunner(command="record()", iterPeriod=1)]
O.run(n_steps, True)

import yade.config  # noqa: E402
json.dump(dict(code="yade", version=yade.config.version, k=k, h=h, bodies=n_bodies,
               interactions=n_inter, dt=dt, steps=n_steps, loops=loops, cpus=cpus,
               x_driver=O.bodies[drv[0]].state.refPos[0],
               x_mid=O.bodies[mid[0]].state.refPos[0], **probe), open(OUT, "w"))
print(f"yade: k={k} bodies={n_bodies} interactions={n_inter} dt={dt:.4g} steps={n_steps} "
      f"loop={min(loops) if loops else float('nan'):.3f} s")
