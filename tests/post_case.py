"""A small run shared by the post-processing tests (export, render, plot,
reader): a clamped steel beam of 12 × 1 × 3 blocks hit downward at 20 m/s,
with yield (normal criterion, so plastic faces appear at the clamp) and a
pre-cut face at midspan (broken faces with contact from the start), every
field written.  36 bodies, 240 springs, 324 steps, 22 frames."""
import textwrap

from rbsm_dyn.__main__ import main

#: a tiny dynamic cantilever (32 blocks, 10 µs) for command-line tests
TINY = textwrap.dedent("""\
    name: good
    domain: {box: [[0, 0, 0], [0.4, 0.1, 0.1]]}
    mesh: {kind: blocks, divisions: [8, 2, 2]}
    materials:
      steel: {density: 8000, young: 200.0e9, poisson: 0.0}
    groups:
      tip: {box: [[0.35, -1, -1], [1, 1, 1]]}
    boundary: [{face: xmin, fix: all}]
    initial: [{group: tip, velocity: [0, 0, -1.0]}]
    solver: {mode: dynamic, end_time: 1.0e-5}
    output:
      probes: {tip_z: {group: tip, quantity: displacement, component: z, reduce: mean}}
    """)

BEAM = textwrap.dedent("""\
    name: post-beam
    description: small clamped beam hit downward, with a pre-cut face
    domain: {box: [[0, 0, 0], [0.12, 0.01, 0.03]]}
    mesh: {kind: blocks, divisions: [12, 1, 3]}
    materials:
      steel:
        density: 8000
        young: 200.0e9
        poisson: 0.0
        yield: {criterion: normal, stress: 100.0e6}
        friction: 0.3
    groups:
      tip: {box: [[0.11, -1, -1], [1, 1, 1]]}
    boundary: [{face: xmin, fix: all}]
    cuts:
      - {point: [0.06, 0, 0], normal: [1, 0, 0], within: [[0.055, -1, 0.015], [0.065, 1, 1]]}
    initial: [{velocity: [0, 0, -20.0]}]
    solver: {mode: dynamic, end_time: 2.0e-4}
    output:
      interval: 1.0e-5
      fields: [position, orientation, velocity, angular_velocity, spring_state]
      probes:
        tip_z: {group: tip, quantity: displacement, component: z, reduce: mean}
    """)


def run_beam(folder, text=BEAM, *args):
    """Write the case to folder/beam.yaml, run it, return the history path."""
    case = folder / "beam.yaml"
    case.write_text(text, encoding="utf-8")
    out = folder / "beam.h5"
    assert main([str(case), "--out", str(out), "--quiet", *map(str, args)]) == 0
    return out
