"""python -m rbsm_dyn render|plot RUN.h5 [options]: rbsm_dyn/io/render.py."""
import importlib

from .args import post_parser


def main(argv, command="render"):
    """render | plot RUN.h5: io/render.py's add_arguments(parser) and
    main(args), for plot add_plot_arguments and main_plot."""
    mod = importlib.import_module(".io.render", __package__.rpartition(".")[0])
    p = post_parser(command, mod)
    if command == "plot":
        mod.add_plot_arguments(p)
        return mod.main_plot(p.parse_args(argv))
    mod.add_arguments(p)
    return mod.main(p.parse_args(argv))
