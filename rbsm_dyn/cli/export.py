"""python -m rbsm_dyn export RUN.h5 [options]: rbsm_dyn/io/export.py."""
import importlib

from .args import post_parser


def main(argv):
    """export RUN.h5: io/export.py's add_arguments(parser) and main(args)."""
    mod = importlib.import_module(".io.export", __package__.rpartition(".")[0])
    p = post_parser("export", mod)
    mod.add_arguments(p)
    return mod.main(p.parse_args(argv))
