"""Reproductions of the published results liecontrol builds on, one module per paper.

Each module has ``NAME`` (the CLI name), ``CITATION``, ``SUMMARY`` (one line) and
``main(out_dir, quick=False) -> int``; it writes a Markdown table with one verdict per published
claim (REPRODUCED / PARTLY / NOT REPRODUCED / CALIBRATED, see :mod:`._common`) and a sensitivity
table over the parameters the paper does not give. Run one with::

    python -m benchmarks reproduce NAME --out DIR [--quick]
    python -m benchmarks reproduce --list
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["REPRODUCTIONS", "available", "load"]

#: CLI name → module (in ``benchmarks.reproductions``), in listing order.
REPRODUCTIONS: dict[str, str] = {
    "adrc-sgcmg": "adrc_sgcmg",
    "strong-tracking-ukf": "strong_tracking_ukf",
    "geometric-survey-lemmas": "geometric_survey_lemmas",
    "rotating-payload": "rotating_payload",
    "terminal-sliding-mode-rvd": "terminal_sliding_mode_rvd",
}


def available() -> list[str]:
    """The reproduction names, in listing order."""
    return list(REPRODUCTIONS)


def load(name: str) -> ModuleType:
    """The module of reproduction ``name``; unknown names raise a ``ValueError`` listing the
    valid ones."""
    if name not in REPRODUCTIONS:
        raise ValueError(
            f"name: unknown reproduction {name!r}; valid reproductions: {', '.join(available())}"
        )
    return importlib.import_module(f"{__name__}.{REPRODUCTIONS[name]}")
