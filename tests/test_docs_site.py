"""The docs site stays complete: every page is reachable, every public module is documented.

- every ``docs/**/*.md`` page is in the ``nav`` of ``mkdocs.yml`` (a page left out would be built
  but unreachable, and ``mkdocs build --strict`` only warns about it in some versions), and every
  nav entry exists;
- every module with an ``__all__`` has an entry on an API page (``::: module`` or
  ``<!-- api:package module -->``), so a new public module cannot be forgotten, and every API
  entry names a real module;
- every ``<!-- registry:NAME -->`` marker on a page has a generator, and the generated blocks agree
  with the registry they describe (hand-counted here through the public registry API);
- the README's quick start and the getting-started page give the same two commands.

The strict build itself (``mkdocs build --strict``) runs in ``.ci/run``: with mkdocstrings it
takes longer than a unit test should.
"""

from __future__ import annotations

import ast
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PACKAGES = ("liecontrol", "spacecraft", "benchmarks")

#: Pages deliberately not in the nav (none today): {path relative to docs/: reason}.
NOT_IN_NAV: dict[str, str] = {}


def _load_docs_module(name: str):
    spec = importlib.util.spec_from_file_location(f"_docs_{name}", DOCS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod


def _nav_pages() -> list[str]:
    """Every page path in mkdocs.yml's nav (read as text: the file uses no YAML tags there,
    but parsing only the nav block keeps the test independent of PyYAML's presence)."""
    text = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    nav = text[text.index("\nnav:") :]
    return re.findall(r"[\s:-]\s*([\w/.-]+\.md)\s*$", nav, flags=re.MULTILINE)


def _public_modules() -> dict[str, Path]:
    """Dotted name → file of every module that defines ``__all__`` (read by AST, so optional
    dependencies need not be installed), skipping private modules (``_name``)."""
    out: dict[str, Path] = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if any(p.startswith("_") and p not in ("__init__", "__main__") for p in parts):
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"))
            has_all = any(
                isinstance(node, (ast.Assign, ast.AnnAssign))
                and any(
                    getattr(t, "id", None) == "__all__"
                    for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
                )
                for node in tree.body
            )
            if has_all:
                name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
                out[name] = path
    return out


def _api_entries() -> dict[str, str]:
    """Module → API page for every ``::: module`` and ``<!-- api:package module -->``."""
    entries: dict[str, str] = {}
    pattern = re.compile(
        r"^(?:::: ([\w.]+)|<!--\s*api:package\s+([\w.]+)\s*-->)\s*$", re.MULTILINE
    )
    for page in sorted((DOCS / "api").glob("*.md")):
        for m in pattern.finditer(page.read_text(encoding="utf-8")):
            entries[m.group(1) or m.group(2)] = page.name
    return entries


def test_every_page_is_in_the_nav_and_every_nav_entry_exists():
    nav = _nav_pages()
    assert nav, "no pages found in the nav of mkdocs.yml"
    dupes = sorted({p for p in nav if nav.count(p) > 1})
    assert not dupes, f"pages listed twice in the nav: {dupes}"
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    missing = sorted(pages - set(nav) - set(NOT_IN_NAV))
    assert not missing, f"docs pages not in mkdocs.yml's nav (add them or NOT_IN_NAV): {missing}"
    dangling = sorted(set(nav) - pages)
    assert not dangling, f"nav entries without a page: {dangling}"


def test_every_public_module_has_an_api_entry():
    modules = _public_modules()
    # the walk must see the families we know exist, or it proves nothing
    for expected in ("liecontrol.lie.so3", "liecontrol.control", "spacecraft.simulator",
                     "benchmarks.runner"):
        assert expected in modules, f"module discovery missed {expected}"
    entries = _api_entries()
    missing = sorted(set(modules) - set(entries))
    assert not missing, (
        f"public modules (they define __all__) without an API entry in docs/api/*.md: {missing}"
    )


def test_every_api_entry_is_a_real_module():
    modules = _public_modules()
    entries = _api_entries()
    unknown = sorted(
        f"{m} ({page})" for m, page in entries.items() if m not in modules
        and not (ROOT / Path(*m.split("."))).with_suffix(".py").exists()
        and not (ROOT / Path(*m.split(".")) / "__init__.py").exists()
    )
    assert not unknown, f"API entries naming no module: {unknown}"


def test_api_pages_are_in_the_nav():
    nav = set(_nav_pages())
    api_pages = {f"api/{p.name}" for p in (DOCS / "api").glob("*.md")}
    assert api_pages <= nav, sorted(api_pages - nav)


def test_registry_markers_have_generators():
    gen = _load_docs_module("gen_registry")
    used: set[str] = set()
    for page in DOCS.rglob("*.md"):
        used |= set(re.findall(r"<!--\s*registry:([\w-]+)\s*-->", page.read_text("utf-8")))
    assert {"suites", "scenarios", "controllers"} <= used, sorted(used)
    unknown = sorted(used - set(gen.GENERATORS))
    assert not unknown, f"registry markers without a generator: {unknown}"
    with pytest.raises(ValueError, match=r"^name: unknown registry block 'nope'"):
        gen.render("nope")


def test_generated_suite_sizes_match_the_registry():
    from benchmarks.controllers import CONTROLLERS, quick_controllers
    from benchmarks.scenarios import SUITES

    gen = _load_docs_module("gen_registry")
    counts = gen.suite_counts()
    quick = SUITES["quick"].scenarios
    q_names = quick_controllers()
    # independent count: plant membership and excluded tags, straight from the metadata
    # (no quick-suite pair is refused by the tuning protocol)
    runs = sum(
        1
        for s in quick
        for c in q_names
        if s.plant in CONTROLLERS[c].plants and not CONTROLLERS[c].exclude_tags & set(s.tags)
    )
    assert counts["quick"] == {
        "scenarios": len(quick),
        "controllers": len(q_names),
        "runs": runs,
        "not_applicable": len(quick) * len(q_names) - runs,
    }
    assert counts["full"]["scenarios"] == len(SUITES["full"].scenarios)
    assert counts["full"]["controllers"] == len(CONTROLLERS)
    table = gen.render("suites")
    assert f"{len(quick)} scenarios × {len(q_names)} quick controllers" in table
    for name in SUITES:
        assert f"`{name}`" in table
    ctable = gen.render("controllers")
    assert all(f"`{c}`" in ctable for c in CONTROLLERS)
    assert ctable.count("\n") == len(CONTROLLERS) + 1  # header, rule, one row each


def test_quick_start_commands_agree():
    fence = re.compile(r"```bash\n(.*?)```", re.DOTALL)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("## Quick start") :]
    section = section[: section.index("\n## ", 1)]
    commands = [b.strip() for b in fence.findall(section)]
    assert commands == [
        "pip install -e . && liecontrol-bench run --suite quick --out report/",
        'pip install -e ".[dev]" && python -m pytest -q',
    ]
    started = (DOCS / "getting_started.md").read_text(encoding="utf-8")
    first = fence.search(started).group(1).strip().splitlines()
    assert first == commands


def test_sphinx_roles_become_optional_cross_references():
    griffe = pytest.importorskip("griffe", reason="griffe comes with the [docs] extra")
    roles = _load_docs_module("griffe_sphinx")
    pkg = griffe.load("liecontrol.integrators", search_paths=[str(ROOT)])
    out = roles.rewrite(
        "See :mod:`.rk`, :class:`~liecontrol.lie.SO3` and :func:`rkmk4_step`; also::\n\n"
        "    x = 1\n",
        pkg,
    )
    # relative module, shortened title, a bare name resolved through the package's imports
    assert '<autoref identifier="liecontrol.integrators.rk" optional><code>.rk</code>' in out
    assert '<autoref identifier="liecontrol.lie.SO3" optional><code>SO3</code>' in out
    assert 'identifier="liecontrol.integrators.rk.rkmk4_step"' in out
    # the reST literal marker becomes a colon; the indented block stays a code block
    assert "also:\n\n    x = 1\n" in out
    assert ":mod:" not in out and ":class:" not in out and ":func:" not in out
    # an unknown bare name keeps its text as identifier (rendered as plain code, no link)
    assert 'identifier="NoSuchThing"' in roles.rewrite(":class:`NoSuchThing`", pkg)


def test_package_block_links_every_reexport_to_its_definition():
    pytest.importorskip("griffe", reason="griffe comes with the [docs] extra")
    pytest.importorskip("mkdocs", reason="mkdocs comes with the [docs] extra")
    import liecontrol.control as control

    hooks = _load_docs_module("hooks")
    block = hooks.package_block("liecontrol.control")
    assert block.startswith("::: liecontrol.control\n    options:\n      members: false\n")
    for name in control.__all__:
        obj = getattr(control, name)
        assert f"| [`{name}`][{obj.__module__}.{obj.__qualname__}] | `{obj.__module__}` |" in block
