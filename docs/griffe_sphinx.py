"""Griffe extension of the docs build: render the reST bits of our docstrings as Markdown.

The docstrings use Sphinx cross-reference roles (``:class:`~liecontrol.lie.SO3```,
``:func:`simulate```, ``:mod:`.rk```) and reST literal-block markers (a paragraph ending in
``::``). mkdocstrings renders docstrings as Markdown, where both would show up verbatim. Before
the docstrings are parsed this extension rewrites

- a role into an *optional* cross-reference (``<autoref identifier=... optional>``): a link to
  the object's API entry when the object is rendered, plain code otherwise (a private helper,
  the standard library) — never a broken link. Targets are resolved like Sphinx does: a dotted
  path as given, ``.name`` relative to the current package, a bare name through the scope of the
  documented object (its members, its module's imports), ``~`` shows only the last component;
- a trailing ``::`` into ``:`` (the indented block that follows is already a Markdown code block).

Loaded by mkdocstrings (``extensions:`` in ``mkdocs.yml``).
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

__all__ = ["SphinxRoles", "rewrite"]

ROLE = re.compile(r":(?:py:)?(class|func|meth|mod|data|attr|exc|obj|const):`([^`]+)`")
LITERAL_MARKER = re.compile(r"(?<=\S)::[ \t]*$", re.MULTILINE)


def _module_of(obj: griffe.Object) -> griffe.Module:
    while not obj.is_module:
        obj = obj.parent  # type: ignore[assignment]
    return obj  # type: ignore[return-value]


def _resolve(obj: griffe.Object, target: str) -> str:
    """Full dotted path of ``target`` seen from ``obj`` (best effort; the target itself if
    nothing matches)."""
    if target.startswith("."):
        module = _module_of(obj)
        package = module if module.is_init_module else module.parent
        base = package.path if package is not None else module.path
        level = len(target) - len(target.lstrip("."))
        parts = base.split(".")
        if level > 1:
            parts = parts[: len(parts) - (level - 1)]
        return ".".join([*parts, target.lstrip(".")])
    head, _, rest = target.partition(".")
    scope: griffe.Object | None = obj
    while scope is not None:
        if head in scope.members:
            member = scope.members[head]
            path = member.path
            try:
                if member.is_alias:
                    path = member.target_path
            except Exception:  # noqa: BLE001 - an unresolvable alias: keep its own path
                pass
            return f"{path}.{rest}" if rest else path
        if scope.is_module and head in scope.imports:
            path = scope.imports[head]
            return f"{path}.{rest}" if rest else path
        scope = scope.parent
    return target


def rewrite(text: str, obj: griffe.Object) -> str:
    """``text`` with its Sphinx roles and ``::`` markers turned into Markdown (see module)."""

    def role(m: re.Match) -> str:
        raw = m.group(2).strip()
        short = raw.startswith("~")
        target = raw.lstrip("~")
        # an explicit title: :class:`title <target>`
        explicit = re.fullmatch(r"(.*?)\s*<([^>]+)>", target)
        if explicit:
            title, target = explicit.group(1), explicit.group(2)
        else:
            title = target.rsplit(".", 1)[-1] if short else target
        identifier = _resolve(obj, target)
        return (
            f'<autoref identifier="{html.escape(identifier, quote=True)}" optional>'
            f"<code>{html.escape(title)}</code></autoref>"
        )

    text = ROLE.sub(role, text)
    return LITERAL_MARKER.sub(":", text)


class SphinxRoles(griffe.Extension):
    """Rewrite every docstring of a loaded package (see the module docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        seen: set[int] = set()
        stack: list[griffe.Object] = [pkg]
        while stack:
            obj = stack.pop()
            if id(obj) in seen:
                continue
            seen.add(id(obj))
            if obj.docstring is not None:
                obj.docstring.value = rewrite(obj.docstring.value, obj)
            stack.extend(m for m in obj.members.values() if not m.is_alias)
