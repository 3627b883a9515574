"""Test helper: parse a reproduction's ``table.md`` with a real Markdown parser (markdown-it-py,
CommonMark + GFM tables) and check that every table renders with its declared columns."""

from __future__ import annotations

import re

from markdown_it import MarkdownIt

from benchmarks.reproductions._common import CLAIM_COLUMNS, VERDICTS

_PIPE = re.compile(r"(?<!\\)\|")
#: A paper cited by an internal number ("seed 003", "seed-000") or the internal spec.
PAPER_BY_NUMBER = re.compile(r"seed[\s_-]*0\d\d|\bSPEC\b", re.IGNORECASE)


def _source_cells(line: str) -> int:
    """Cells of one GFM table source row: unescaped pipes, minus the outer two."""
    return len(_PIPE.findall(line.strip())) - 1


def parse_tables(md: str) -> list[dict]:
    """Every table of ``md`` as rendered: ``{"header": [...], "rows": [[...], ...]}`` (cell
    text = the inline content with markup removed). Asserts that every source row has as many
    cells as its header — a GFM renderer silently drops surplus cells (what an unescaped ``|``
    in a cell causes), so the rendered table alone would hide the breakage."""
    lines = md.splitlines()
    tokens = MarkdownIt("commonmark").enable("table").parse(md)
    tables: list[dict] = []
    cur: dict | None = None
    row: list[str] | None = None
    for i, tok in enumerate(tokens):
        if tok.type == "table_open":
            cur = {"header": [], "rows": []}
        elif tok.type == "table_close":
            tables.append(cur)
            cur = None
        elif tok.type == "tr_open":
            row = []
            src = lines[tok.map[0]]
            row_src_cells = _source_cells(src)
        elif tok.type == "tr_close":
            assert cur is not None and row is not None
            if not cur["header"]:
                cur["header"] = row
            else:
                assert row_src_cells == len(cur["header"]), (
                    f"row has {row_src_cells} cells, header {len(cur['header'])}: {src}")
                cur["rows"].append(row)
        elif tok.type == "inline" and row is not None and tokens[i - 1].type in ("th_open",
                                                                                "td_open"):
            text = "".join(c.content for c in (tok.children or []) if c.type in ("text",
                                                                                  "code_inline"))
            row.append(text.strip())
    return tables


def check_reproduction_markdown(md: str, sensitivity: bool) -> dict:
    """Every table parses with its declared columns; the claims table has exactly
    :data:`CLAIM_COLUMNS` and a verdict from :data:`VERDICTS` in every row; with
    ``sensitivity``, a table whose header starts with "claim" and ends with "sensitivity" and
    whose cells start with ✓/✗/—. Returns ``{"claims": rows, "sensitivity": table or None}``."""
    tables = parse_tables(md)
    assert tables, "no table rendered"
    claims = [t for t in tables if tuple(t["header"]) == CLAIM_COLUMNS]
    assert len(claims) == 1, [t["header"] for t in tables]
    rows = claims[0]["rows"]
    assert rows
    for r in rows:
        assert len(r) == len(CLAIM_COLUMNS)
        assert r[3] in VERDICTS, r
        assert r[0] and r[2] and r[4], r  # claim, measured value and reason survive rendering
    sens = [t for t in tables if t["header"][0] == "claim" and t["header"][-1] == "sensitivity"]
    if sensitivity:
        assert len(sens) == 1
        for r in sens[0]["rows"]:
            assert len(r) == len(sens[0]["header"])
            assert all(c[:1] in "✓✗—" for c in r[1:-1]), r
    return {"claims": rows, "sensitivity": sens[0] if sens else None}
