"""Shared helpers: run a case text through the command line in-process and
read its history."""
import textwrap

import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main


@pytest.fixture
def run_case(tmp_path):
    """run_case(yaml_text, *cli_args) -> History of the run (exit code 0 asserted)."""
    counter = iter(range(1000))

    def run(text, *args):
        k = next(counter)
        path = tmp_path / f"case{k}.yaml"
        path.write_text(textwrap.dedent(text), encoding="utf-8")
        out = tmp_path / f"run{k}.h5"
        code = main([str(path), "--out", str(out), "--quiet", *map(str, args)])
        assert code == 0
        return rbsm_dyn.open_history(out)

    return run
