"""Shared reproduction plumbing: verdicts, sensitivity bookkeeping, Markdown escaping checked
with a real Markdown parser, and config validation."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
from repro_markdown import check_reproduction_markdown, parse_tables

from benchmarks.reproductions._common import (
    CALIBRATED,
    NOT_REPRODUCED,
    PARTLY,
    REPRODUCED,
    Citation,
    Claim,
    SensitivityStudy,
    Variation,
    check_config,
    claims_section,
    md_escape,
    md_table,
    robust_verdict,
    sensitivity_section,
)


def _study() -> SensitivityStudy:
    return SensitivityStudy(
        {"a": "claim |A|", "b": "claim B"},
        [Variation("ours", "x", {"a": (True, "|x| = 1"), "b": (True, "2")}, baseline=True),
         Variation("K", "0.2", {"a": (False, "|x| = 9"), "b": (True, "3")}),
         Variation("F", "3", {"a": (True, "|x| = 2")})],
        note="a | note")


def test_robust_verdict_rules():
    st = _study()
    assert robust_verdict(False, st, "a", "why")[0] == NOT_REPRODUCED
    v, reason = robust_verdict(True, st, "a", "why")
    assert v == PARTLY and reason.endswith("fails at K = 0.2")
    v, reason = robust_verdict(True, st, "b", "why")
    assert v == REPRODUCED and "holds in all 1 variations" in reason
    assert st.tried("b") == 1 and st.failures("a") == ["K = 0.2"]
    assert robust_verdict(True, None, None, "why")[0] == REPRODUCED


def test_claim_rejects_unknown_verdicts():
    with pytest.raises(ValueError, match="^verdict"):
        Claim("c", "p", "m", "PASS", "r")
    with pytest.raises(TypeError, match="^measured"):
        Claim("c", "p", 1.0, REPRODUCED, "r")


def test_escaped_cells_render_as_one_cell_each():
    """Without escaping, '|p − z|' splits the row; the parser then drops the surplus cells
    (the measured value and the verdict disappear). Escaped, every cell survives."""
    raw = "| claim | measured | verdict |\n|---|---|---|\n| c | |p − z| = 1 | OK |\n"
    with pytest.raises(AssertionError, match="row has 5 cells, header 3"):
        parse_tables(raw)
    md = "\n".join(md_table(["claim", "measured", "verdict"], [["c", "|p − z| = 1", "OK"]]))
    (t,) = parse_tables(md)
    assert t["rows"] == [["c", "|p − z| = 1", "OK"]]
    assert md_escape("a|b\nc") == "a\\|b c"
    with pytest.raises(ValueError, match="^rows"):
        md_table(["a", "b"], [["1"]])


def test_claims_and_sensitivity_sections_parse():
    claims = [Claim("x: |a| small", "< 1", "|a| = 0.5", REPRODUCED, "ok | fine"),
              Claim("calibrated row", "1", "1", CALIBRATED, "we fitted it")]
    md = "\n".join(claims_section(claims) + sensitivity_section(_study()))
    parsed = check_reproduction_markdown(md, sensitivity=True)
    assert [r[3] for r in parsed["claims"]] == [REPRODUCED, CALIBRATED]
    assert parsed["claims"][0][2] == "|a| = 0.5" and parsed["claims"][0][4] == "ok | fine"
    sens = parsed["sensitivity"]
    assert sens["header"] == ["claim", "ours = x (ours)", "K = 0.2", "F = 3", "sensitivity"]
    assert sens["rows"][1][3] == "—"  # claim B not evaluated at F = 3
    assert "1 claims counted: 1 reproduced" in md and "1 calibration rows" in md


def test_citation_string():
    c = Citation("Liu, Tang & Yu", "A title", "A Journal 30(2)", "2008")
    assert str(c) == "Liu, Tang & Yu, “A title”, A Journal 30(2), 2008."


@dataclass(frozen=True)
class _Cfg:
    dt: float = 0.1
    n: int = 3
    a0: tuple[float, float] = (1.0, -2.0)
    values: tuple[float, ...] = (0.5,)
    opt: tuple[float, ...] | None = None
    flag: bool = True

    def __post_init__(self) -> None:
        check_config(self, positive=("dt", "n"), signed=("a0",))


def test_check_config():
    c = _Cfg(dt=1, values=[1, 2])
    assert c.dt == 1.0 and isinstance(c.dt, float) and c.values == (1.0, 2.0)
    for kw, match in (({"dt": -1.0}, "^dt: must be > 0"), ({"dt": float("nan")}, "^dt: must be "
                      "finite"), ({"n": 0}, "^n: must be > 0"), ({"a0": (1.0,)}, "^a0: expected 2"),
                      ({"values": (-1.0,)}, r"^values\[0\]: must be >= 0")):
        with pytest.raises(ValueError, match=match):
            _Cfg(**kw)
    for kw, match in (({"dt": "x"}, "^dt: expected a real"), ({"n": 2.5}, "^n: expected an "
                      "integer"), ({"values": "ab"}, "^values: expected a tuple"),
                      ({"flag": 1}, "^flag: expected True"), ({"dt": 1j}, "^dt: expected a real")):
        with pytest.raises(TypeError, match=match):
            _Cfg(**kw)
    assert _Cfg(opt=(1.0, 2.0)).opt == (1.0, 2.0) and _Cfg(a0=(-1.0, -1.0)).a0 == (-1.0, -1.0)
