"""MkDocs hook of the liecontrol site (``hooks:`` in ``mkdocs.yml``).

Two kinds of marker are replaced before a page is rendered:

- ``<!-- registry:NAME -->``: a table generated from the benchmark registry by
  ``docs/gen_registry.py`` (suites with their sizes, scenarios, controllers, reproductions), so
  counts and lists are never typed by hand.
- ``<!-- api:package MODULE -->`` (API pages): the package's docstring, the members it defines
  itself, and a table of the names it re-exports, each linked to the page section of the module
  that defines it (the definitions are rendered once, under their own module).

An unknown marker name fails the build, so a typo cannot silently leave a hole in a page.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from mkdocs.exceptions import PluginError

ROOT = Path(__file__).resolve().parents[1]
DOCS = Path(__file__).resolve().parent

#: ``<!-- registry:NAME -->`` and ``<!-- api:package MODULE -->`` markers.
REGISTRY_MARKER = re.compile(r"<!--\s*registry:([\w-]+)\s*-->")
PACKAGE_MARKER = re.compile(r"<!--\s*api:package\s+([\w.]+)\s*-->")

_CACHE: dict[str, str] = {}


def _import_generators():
    for p in (str(ROOT), str(DOCS)):
        if p not in sys.path:
            sys.path.insert(0, p)
    import gen_registry

    return gen_registry


def _registry_block(name: str, page: str) -> str:
    if name not in _CACHE:
        gen = _import_generators()
        try:
            _CACHE[name] = gen.render(name)
        except ValueError as exc:
            raise PluginError(f"{page}: {exc}") from exc
    return _CACHE[name]


def package_block(module: str) -> str:
    """The Markdown for ``<!-- api:package MODULE -->``: a mkdocstrings directive showing the
    package docstring and its own members, then the re-exported names as a linked table."""
    import griffe

    try:
        pkg = griffe.load(module, search_paths=[str(ROOT)])
    except (ImportError, ModuleNotFoundError) as exc:
        raise PluginError(f"api:package {module}: cannot load the package ({exc})") from exc
    exports = list(pkg.exports or [])
    # members defined in the package itself (submodules listed in __all__ get their own section)
    own = [
        n
        for n in exports
        if n in pkg.members and not pkg.members[n].is_alias and not pkg.members[n].is_module
    ]
    rows = []
    for name in exports:
        obj = pkg.members.get(name)
        if obj is None or not obj.is_alias:
            continue
        target = obj.final_target.path
        where = target.rsplit(".", 1)[0]
        rows.append(f"| [`{name}`][{target}] | `{where}` |")
    members = "[" + ", ".join(own) + "]" if own else "false"
    out = [
        f"::: {module}",
        "    options:",
        f"      members: {members}",
        "",
    ]
    if rows:
        out += [
            f"`{module}` re-exports, so `from {module} import NAME` works for:",
            "",
            "| name | defined in |",
            "|---|---|",
            *rows,
            "",
        ]
    return "\n".join(out)


def on_page_markdown(markdown: str, page, config, files) -> str:
    src = page.file.src_path

    def registry(m: re.Match) -> str:
        return _registry_block(m.group(1), src)

    def package(m: re.Match) -> str:
        return package_block(m.group(1))

    markdown = REGISTRY_MARKER.sub(registry, markdown)
    return PACKAGE_MARKER.sub(package, markdown)
