"""Every ```python block in README.md and docs/*.md runs as written, **on its own**.

Each block runs in a fresh namespace (a reader copies one example, not the page), in a temporary
working directory, with matplotlib's non-interactive backend; so every block has its own imports
and data. A block preceded by the line ``<!-- no-run -->`` is skipped (for shell-dependent
snippets); one preceded by ``<!-- requires: MODULE -->`` is skipped where that optional module
is not installed (e.g. ``jax``, the ``[jax]`` extra, which CI does not install). Warnings a block
emits are shown in the test's output, not hidden.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(
    r"(<!-- no-run -->\s*\n)?(?:<!-- requires: ([\w.]+) -->\s*\n)?```python\n(.*?)```", re.DOTALL
)


def _blocks(page: Path) -> list[tuple[int, str, str | None]]:
    """``(line number, code, optional module it needs)`` of the page's runnable blocks."""
    text = page.read_text(encoding="utf-8")
    return [
        (text.count("\n", 0, m.start(3)) + 1, m.group(3), m.group(2))
        for m in BLOCK.finditer(text)
        if not m.group(1)
    ]


CASES = [
    pytest.param(page, line, code, needs, id=f"{page.name}:{line}")
    for page in PAGES
    for line, code, needs in _blocks(page)
]


@pytest.mark.parametrize(("page", "line", "code", "needs"), CASES)
def test_example_runs_alone(
    page: Path, line: int, code: str, needs: str | None, tmp_path, monkeypatch
):
    if needs is not None:
        pytest.importorskip(needs)
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": f"docs_{page.stem}_{line}"}
    try:
        exec(compile(code, f"{page.name}:{line}", "exec"), namespace)
    except Exception as exc:  # pragma: no cover - the message is the point
        raise AssertionError(
            f"{page.name}, the example at line {line} fails when run alone: {exc!r}\n{code}"
        ) from exc
    finally:
        import matplotlib.pyplot as plt

        plt.close("all")


def test_every_page_with_examples_is_collected():
    assert CASES, "no ```python block found in README.md or docs/*.md"
