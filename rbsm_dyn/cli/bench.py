"""python -m rbsm_dyn bench [options]: times the explicit loop (rbsm_dyn/bench.py)."""


def main(argv):
    from ..bench import main as bench_main
    return bench_main(argv)
