"""Every ```python block in README.md and docs/*.md runs as written.

Blocks of one page run in order in one namespace (a page's later examples may use earlier
names), in a temporary working directory, with matplotlib's non-interactive backend. A block
preceded by the line ``<!-- no-run -->`` is skipped (for shell-dependent snippets).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"(<!-- no-run -->\s*\n)?```python\n(.*?)```", re.DOTALL)


def _blocks(page: Path) -> list[str]:
    return [m.group(2) for m in BLOCK.finditer(page.read_text(encoding="utf-8")) if not m.group(1)]


@pytest.mark.parametrize("page", [p for p in PAGES if _blocks(p)], ids=lambda p: p.name)
def test_page_examples_run(page: Path, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": f"docs_{page.stem}"}
    for i, code in enumerate(_blocks(page)):
        try:
            exec(compile(code, f"{page.name}[block {i}]", "exec"), namespace)
        except Exception as exc:  # pragma: no cover - the message is the point
            raise AssertionError(f"{page.name}, example {i} failed: {exc!r}\n{code}") from exc
    import matplotlib.pyplot as plt

    plt.close("all")
