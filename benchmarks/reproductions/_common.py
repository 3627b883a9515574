"""Shared plumbing of the paper reproductions: citations, verdicts, sensitivity tables, Markdown
that renders, the output files and the module CLI.

Every reproduction keeps its own science (``run``, ``_markdown``, ``_figures``); how a published
claim is judged and how the tables are written lives here, so that all five speak one language.

Verdicts (one per published claim, with a one-line reason):

* ``REPRODUCED`` — the claim holds at our choice of every parameter the paper does not give *and*
  at every other value of those parameters we tried (the sensitivity table);
* ``PARTLY`` — it holds at our choices but not at some plausible other value, or only part of a
  compound claim holds (e.g. "A beats B and C" where A ties C);
* ``NOT REPRODUCED`` — it does not hold at our choices;
* ``CALIBRATED`` — the row is the calibration target itself (we fitted an unpublished quantity so
  that this row matches): shown for completeness, never counted as evidence.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import numbers
import pathlib
import sys
import types
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

__all__ = [
    "REPRODUCED",
    "PARTLY",
    "NOT_REPRODUCED",
    "CALIBRATED",
    "VERDICTS",
    "Citation",
    "Claim",
    "Variation",
    "SensitivityStudy",
    "md_escape",
    "md_table",
    "claims_section",
    "sensitivity_section",
    "robust_verdict",
    "check_config",
    "exit_code",
    "write_outputs",
    "save_figure",
    "cli",
]

REPRODUCED = "REPRODUCED"
PARTLY = "PARTLY"
NOT_REPRODUCED = "NOT REPRODUCED"
CALIBRATED = "CALIBRATED"
#: The allowed verdicts, in table order.
VERDICTS = (REPRODUCED, PARTLY, NOT_REPRODUCED, CALIBRATED)


@dataclass(frozen=True)
class Citation:
    """A paper: authors (family names, "A, B & C"), title, venue (journal, volume(issue)) and
    year. ``str()`` gives the one-line reference printed by every reproduction."""

    authors: str
    title: str
    venue: str
    year: str
    note: str = ""

    def __str__(self) -> str:
        tail = f" ({self.note})" if self.note else ""
        return f"{self.authors}, \u201c{self.title}\u201d, {self.venue}, {self.year}{tail}."


@dataclass(frozen=True)
class Claim:
    """One published claim and what we measured.

    ``claim``: the paper's statement in our words; ``published``: its number or wording;
    ``measured``: our number(s); ``verdict``: one of :data:`VERDICTS`; ``reason``: one line
    saying why this verdict (the threshold used, the sensitivity that moved it, the tie...).
    """

    claim: str
    published: str
    measured: str
    verdict: str
    reason: str

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict: expected one of {VERDICTS}, got {self.verdict!r}")
        for name in ("claim", "published", "measured", "reason"):
            if not isinstance(getattr(self, name), str):
                raise TypeError(f"{name}: expected str, got {type(getattr(self, name)).__name__}")

    def as_dict(self) -> dict[str, str]:
        return asdict(self)


@dataclass(frozen=True)
class Variation:
    """One row of a sensitivity table: ``parameter`` set to ``value`` (everything else at our
    baseline choice; ``baseline`` marks the row that *is* the baseline). ``outcomes`` maps a
    claim key to ``(holds, measured text)``."""

    parameter: str
    value: str
    outcomes: Mapping[str, tuple[bool, str]]
    baseline: bool = False


@dataclass(frozen=True)
class SensitivityStudy:
    """A sensitivity table: the claim keys and their short column labels (``claims``: key →
    label), the variations, and a note saying what was chosen (horizon, seeds...)."""

    claims: Mapping[str, str]
    variations: Sequence[Variation]
    note: str = ""
    parameters: Mapping[str, str] = field(default_factory=dict)

    def failures(self, key: str) -> list[str]:
        """``"parameter = value"`` of every non-baseline variation where ``key`` fails."""
        return [f"{v.parameter} = {v.value}" for v in self.variations
                if not v.baseline and key in v.outcomes and not v.outcomes[key][0]]

    def tried(self, key: str) -> int:
        """How many non-baseline variations evaluated ``key``."""
        return sum(1 for v in self.variations if not v.baseline and key in v.outcomes)

    def sensitivity(self, key: str) -> str:
        """One phrase: 'holds in all N variations' or 'fails at p = v, ...'."""
        n = self.tried(key)
        if n == 0:
            return "not varied"
        bad = self.failures(key)
        if not bad:
            return f"holds in all {n} variations"
        return f"fails in {len(bad)} of {n}: " + "; ".join(bad)

    def as_dict(self) -> dict[str, Any]:
        return {
            "claims": dict(self.claims),
            "note": self.note,
            "parameters": dict(self.parameters),
            "variations": [
                {"parameter": v.parameter, "value": v.value, "baseline": v.baseline,
                 "outcomes": {k: {"holds": bool(o[0]), "measured": o[1]}
                              for k, o in v.outcomes.items()}}
                for v in self.variations
            ],
        }


def robust_verdict(
    holds: bool, study: SensitivityStudy | None, key: str | None, why: str
) -> tuple[str, str]:
    """Verdict and reason of a claim from its baseline outcome and its sensitivity row.

    ``holds``: the claim at our choices; ``why``: the one-line measured basis (threshold...).
    Fails at baseline → NOT REPRODUCED; holds and every variation of ``key`` in ``study`` holds
    → REPRODUCED; holds but some variation fails → PARTLY, naming the failing values.
    """
    if not holds:
        return NOT_REPRODUCED, why
    if study is None or key is None or study.tried(key) == 0:
        return REPRODUCED, why + " (sensitivity not evaluated for this row)"
    bad = study.failures(key)
    if not bad:
        return REPRODUCED, why + f"; robust: {study.sensitivity(key)}"
    return PARTLY, why + f" at our choices, but fails at {'; '.join(bad)}"


# --------------------------------------------------------------------------- configs


def _real(name: str, v: object, positive: bool, nonneg: bool) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name}: expected a real number, got {type(v).__name__} {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"{name}: must be finite, got {x}")
    if positive and not x > 0:
        raise ValueError(f"{name}: must be > 0, got {x}")
    if nonneg and x < 0:
        raise ValueError(f"{name}: must be >= 0, got {x}")
    return x


def _check_value(name: str, v: object, tp: Any, positive: bool, nonneg: bool) -> object:
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if v is None and type(None) in args:
            return None
        (tp,) = [a for a in args if a is not type(None)]
        return _check_value(name, v, tp, positive, nonneg)
    if tp is bool:
        if not isinstance(v, bool):
            raise TypeError(f"{name}: expected True or False, got {v!r}")
        return v
    if tp is str:
        if not isinstance(v, str):
            raise TypeError(f"{name}: expected a string, got {type(v).__name__}")
        return v
    if tp is int:
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            raise TypeError(f"{name}: expected an integer, got {type(v).__name__} {v!r}")
        x = int(v)
        if (positive and x <= 0) or (nonneg and x < 0):
            raise ValueError(f"{name}: must be {'> 0' if positive else '>= 0'}, got {x}")
        return x
    if tp is float:
        return _real(name, v, positive, nonneg)
    if origin is tuple:
        if isinstance(v, (str, bytes)) or not isinstance(v, Sequence):
            raise TypeError(f"{name}: expected a tuple, got {type(v).__name__}")
        items = list(v)
        if not (len(args) == 2 and args[1] is Ellipsis) and len(items) != len(args):
            raise ValueError(f"{name}: expected {len(args)} values, got {len(items)}")
        elem = args[0]
        return tuple(_check_value(f"{name}[{i}]", x, elem, positive, nonneg)
                     for i, x in enumerate(items))
    return v


def check_config(cfg: Any, positive: Iterable[str] = (), signed: Iterable[str] = ()) -> None:
    """Validate a frozen config dataclass from its ``__post_init__`` (normalising values in
    place): every field must match its annotation (``float``: a finite real number; ``int``: an
    integer; tuples: the annotated length and element type; ``X | None``); numbers are ``>= 0``
    unless named in ``signed``, and ``> 0`` when named in ``positive``. Errors start with the
    field's name (``"dt: must be > 0, got -1.0"``)."""
    positive, signed = set(positive), set(signed)
    hints = typing.get_type_hints(type(cfg))
    for f in dataclasses.fields(cfg):
        v = _check_value(f.name, getattr(cfg, f.name), hints[f.name], f.name in positive,
                         f.name not in signed)
        object.__setattr__(cfg, f.name, v)


# --------------------------------------------------------------------------- Markdown


_MD_CELL = str.maketrans({"|": "\\|", "\n": " ", "\r": " "})


def md_escape(text: object) -> str:
    """``text`` as one GFM table cell: ``|`` escaped (a bare ``|`` ends the cell — ``|p − z|``
    would split the row and push the last columns out of the table), line breaks flattened."""
    return str(text).translate(_MD_CELL).strip()


def md_table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> list[str]:
    """Lines of a GFM table, every cell escaped with :func:`md_escape`; each row must have
    ``len(header)`` cells."""
    header = [md_escape(h) for h in header]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for i, row in enumerate(rows):
        cells = [md_escape(c) for c in row]
        if len(cells) != len(header):
            raise ValueError(f"rows: row {i} has {len(cells)} cells, header has {len(header)}")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


#: Columns of the published-vs-measured table.
CLAIM_COLUMNS = ("published claim", "published", "measured", "verdict", "reason")


def verdict_counts(claims: Sequence[Claim]) -> dict[str, int]:
    return {v: sum(c.verdict == v for c in claims) for v in VERDICTS}


def claims_section(claims: Sequence[Claim]) -> list[str]:
    """Markdown lines of the "Published vs measured" section: one row per claim (columns
    :data:`CLAIM_COLUMNS`) and a count line (CALIBRATED rows shown but not counted)."""
    n = verdict_counts(claims)
    counted = n[REPRODUCED] + n[PARTLY] + n[NOT_REPRODUCED]
    lines = ["", "## Published vs measured", ""]
    lines += md_table(CLAIM_COLUMNS, ((c.claim, c.published, c.measured, f"**{c.verdict}**",
                                       c.reason) for c in claims))
    lines += ["", f"{counted} claims counted: {n[REPRODUCED]} reproduced, {n[PARTLY]} partly, "
              f"{n[NOT_REPRODUCED]} not reproduced; {n[CALIBRATED]} calibration rows shown, "
              "not counted (they are what we fitted)."]
    return lines


def sensitivity_section(study: SensitivityStudy) -> list[str]:
    """Markdown lines of the "Sensitivity" section: one row per claim key, one column per
    variation (``✓``/``✗`` and the measured value; ``—`` where not evaluated), and a last column
    saying how sensitive the claim is (:meth:`SensitivityStudy.sensitivity`)."""
    lines = ["", "## Sensitivity to the parameters the paper does not give", ""]
    if study.note:
        lines += [md_escape(study.note), ""]
    if study.parameters:
        lines += ["Parameters varied one at a time (the rest at our choice):", ""]
        lines += [f"- {md_escape(k)}: {md_escape(v)}" for k, v in study.parameters.items()]
        lines += [""]
    header = ["claim"] + [f"{v.parameter} = {v.value}" + (" (ours)" if v.baseline else "")
                          for v in study.variations] + ["sensitivity"]
    rows = []
    for k, label in study.claims.items():
        cells = [label]
        for v in study.variations:
            if k in v.outcomes:
                ok, txt = v.outcomes[k]
                cells.append(("✓ " if ok else "✗ ") + txt)
            else:
                cells.append("—")
        rows.append(cells + [study.sensitivity(k)])
    lines += md_table(header, rows)
    return lines


def exit_code(claims: Sequence[Claim]) -> int:
    """0: the reproduction ran and every row has a valid verdict (a NOT REPRODUCED verdict is a
    finding, not an error)."""
    return 0 if all(c.verdict in VERDICTS for c in claims) else 1


# --------------------------------------------------------------------------- files


def write_outputs(
    out_dir: pathlib.Path,
    md: str,
    claims: Sequence[Claim],
    payload: Mapping[str, Any],
    *,
    study: SensitivityStudy | None = None,
    figures: Callable[[pathlib.Path], object] | None = None,
) -> None:
    """Create ``out_dir`` and write ``table.md`` (``md``), ``table.csv`` (one row per claim,
    columns claim/published/measured/verdict/reason), ``sensitivity.csv`` (when ``study``;
    columns parameter, value, baseline, then holds/measured per claim) and ``results.json``
    (``payload`` plus ``claims`` and ``sensitivity``; numpy scalars as floats); then call
    ``figures(out_dir)`` if given."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "table.md").write_text(md, encoding="utf-8")
    keys = ["claim", "published", "measured", "verdict", "reason"]
    with open(out_dir / "table.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(c.as_dict() for c in claims)
    doc = dict(payload)
    doc["claims"] = [c.as_dict() for c in claims]
    if study is not None:
        doc["sensitivity"] = study.as_dict()
        ckeys = list(study.claims)
        with open(out_dir / "sensitivity.csv", "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["parameter", "value", "baseline"]
                       + [f"{k}{s}" for k in ckeys for s in ("_holds", "_measured")])
            for v in study.variations:
                cells: list[object] = [v.parameter, v.value, v.baseline]
                for k in ckeys:
                    ok, txt = v.outcomes.get(k, ("", ""))
                    cells += [ok, txt]
                w.writerow(cells)
    (out_dir / "results.json").write_text(
        json.dumps(doc, indent=2, default=float), encoding="utf-8")
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
    """``python -m benchmarks.reproductions.<module> [--out DIR] [--quick]``: parse the
    arguments, run ``main(out, quick)`` and exit with its code."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path(f"reproductions/{name}"))
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    sys.exit(main(a.out, a.quick))
