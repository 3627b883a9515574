"""Output plumbing shared by the seed reproductions: the published-vs-measured table, the
``table.md`` / ``table.csv`` / ``results.json`` files, figure saving and the module CLI.

Every reproduction module keeps its own ``run``, ``_markdown`` and ``_figures`` (the science);
only the writing of what they produce lives here.
"""

from __future__ import annotations

import argparse
import csv
import json
import pathlib
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any

__all__ = ["checks_section", "write_outputs", "save_figure", "cli"]


def checks_section(checks: Sequence[Mapping[str, Any]]) -> list[str]:
    """Markdown lines of the "Published vs measured" section, one table row per check
    (``claim``, ``measured``, ``result``), preceded by a blank line."""
    lines = ["", "## Published vs measured", "", "| published claim | measured | result |",
             "|---|---|---|"]
    lines += [f"| {c['claim']} | {c['measured']} | {c['result']} |" for c in checks]
    return lines


def write_outputs(
    out_dir: pathlib.Path,
    md: str,
    rows: Sequence[Mapping[str, Any]],
    payload: Mapping[str, Any],
    *,
    fieldnames: Sequence[str] | None = None,
    extrasaction: str = "raise",
    figures: Callable[[pathlib.Path], object] | None = None,
) -> None:
    """Create ``out_dir`` and write ``table.md`` (``md``), ``table.csv`` (``rows``; columns
    ``fieldnames``, default the first row's keys) and ``results.json`` (``payload``, numpy
    scalars as floats); then call ``figures(out_dir)`` if given."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "table.md").write_text(md, encoding="utf-8")
    keys = list(rows[0].keys()) if fieldnames is None else list(fieldnames)
    with open(out_dir / "table.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys, extrasaction=extrasaction)
        writer.writeheader()
        writer.writerows(rows)
    (out_dir / "results.json").write_text(
        json.dumps(payload, indent=2, default=float), encoding="utf-8")
    if figures is not None:
        figures(out_dir)


def save_figure(fig: Any, path: pathlib.Path, dpi: int = 110) -> pathlib.Path:
    """Lay out, save and close a matplotlib figure; return ``path``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def cli(main: Callable[[pathlib.Path, bool], int], doc: str, name: str) -> None:
    """``python -m benchmarks.reproductions.<name> [--out DIR] [--quick]``: parse the arguments,
    run ``main(out, quick)`` and exit with its code."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path(f"reproductions/{name}"))
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    sys.exit(main(a.out, a.quick))
