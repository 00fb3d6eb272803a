"""Make examples/quickstart.ipynb from examples/quickstart.py.

The script is the source: cells start at a line ``# %%`` (code) or
``# %% [markdown]`` (markdown, each line's leading ``# `` removed), the
"percent" format that Jupytext, VS Code and Spyder also read.  The test
suite runs the script and checks that the notebook is up to date
(tests/test_examples.py); after editing the script, run

    python examples/sync_notebook.py
"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def cells_of(script_text):
    """[(kind, source)] of a percent-format script."""
    cells, kind, lines = [], None, []

    def flush():
        if kind is not None:
            while lines and not lines[-1].strip():
                lines.pop()
            cells.append((kind, "\n".join(lines)))

    for line in script_text.splitlines():
        if line.startswith("# %%"):
            flush()
            kind = "markdown" if "[markdown]" in line else "code"
            lines = []
        elif kind == "markdown":
            lines.append(line[2:] if line.startswith("# ") else line.lstrip("#"))
        elif kind is not None:
            lines.append(line)
    flush()
    return cells


def notebook_text(script_text):
    cells = []
    for kind, src in cells_of(script_text):
        source = [ln + "\n" for ln in src.split("\n")]
        source[-1] = source[-1].rstrip("\n")
        cell = {"cell_type": kind, "metadata": {}, "source": source}
        if kind == "code":
            cell.update(execution_count=None, outputs=[])
        cells.append(cell)
    nb = {"cells": cells,
          "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python",
                                      "name": "python3"},
                       "language_info": {"name": "python"}},
          "nbformat": 4, "nbformat_minor": 5}
    for i, c in enumerate(nb["cells"]):
        c["id"] = f"cell-{i}"
    return json.dumps(nb, indent=1, ensure_ascii=False) + "\n"


def main(name="quickstart"):
    text = notebook_text((HERE / f"{name}.py").read_text(encoding="utf-8"))
    (HERE / f"{name}.ipynb").write_text(text, encoding="utf-8")
    print(f"wrote {HERE / f'{name}.ipynb'}")


if __name__ == "__main__":
    main(*sys.argv[1:])
