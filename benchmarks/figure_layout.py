"""Programmatic layout check of a matplotlib figure (the report's figures are tested with it).

:func:`layout_problems` draws the figure and lists what a reader would see as broken:

- a text (suptitle, title, axis label, tick label, legend entry, figure text) that reaches
  outside the figure — it would be cut in the saved PNG;
- an annotation placed in an axes (``ax.annotate``, ``ax.text``) that reaches outside that
  axes — a label spilling over the frame into the neighbouring panel or the margin;
- an axis with fewer than two labelled ticks in view (a single label, e.g. a log axis spanning
  less than a decade with its minor labels switched off, gives no scale). A categorical axis
  (fixed tick labels, e.g. scenario names) needs one label per category, at most two.

An empty list means the figure passes. Invisible axes and axes with their axis turned off are
skipped.
"""

from __future__ import annotations

from typing import Any

__all__ = ["layout_problems", "TOLERANCE_PX"]

#: Slack [pixels] of the bounds checks (anti-aliasing, rounding of the text extents).
TOLERANCE_PX = 1.0


def _inside(bb: Any, box: Any, tol: float = TOLERANCE_PX) -> bool:
    return (
        bb.x0 >= box.x0 - tol
        and bb.y0 >= box.y0 - tol
        and bb.x1 <= box.x1 + tol
        and bb.y1 <= box.y1 + tol
    )


def _texts_of_axes(ax: Any) -> list[tuple[str, Any]]:
    """(role, Text) of everything an axes draws that must stay inside the figure."""
    out: list[tuple[str, Any]] = [("title", ax.title)]
    # the left/right titles have no public accessor for their Text artists
    out += [(f"{k} title", getattr(ax, f"_{k}_title", None)) for k in ("left", "right")]
    out += [("x label", ax.xaxis.label), ("y label", ax.yaxis.label)]
    out += [("x offset text", ax.xaxis.get_offset_text()),
            ("y offset text", ax.yaxis.get_offset_text())]
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y")):
        for t in _drawn_ticklabels(axis):
            out.append((f"{name} tick label", t))
    leg = ax.get_legend()
    if leg is not None:
        out += [("legend entry", t) for t in leg.get_texts()]
        if leg.get_title().get_text():
            out.append(("legend title", leg.get_title()))
    return out


def _drawn_ticklabels(axis: Any) -> list[Any]:
    """The tick labels the axis draws: those of the ticks in view (major and minor), both
    sides. ``Axis._update_ticks`` is what ``Axis.draw`` uses to pick them (no public
    equivalent: ``get_majorticklabels`` also returns labels of ticks outside the view)."""
    if not axis.get_visible():
        return []
    out = []
    for tick in axis._update_ticks():
        out += [lab for lab in (tick.label1, tick.label2) if lab.get_visible()]
    return out


def _labelled_ticks(axis: Any) -> int:
    """Ticks in view with a visible, non-empty label (major and minor)."""
    return len({round(float(t.get_position()[0 if axis.axis_name == "x" else 1]), 12)
                for t in _drawn_ticklabels(axis) if t.get_text().strip()})


def _categories(axis: Any) -> int | None:
    """Number of categories of a fixed-label (categorical) axis, else ``None``."""
    from matplotlib.ticker import FixedFormatter

    fmt = axis.get_major_formatter()
    if isinstance(fmt, FixedFormatter):
        return len([s for s in fmt.seq if str(s).strip()])
    return None


def layout_problems(fig: Any) -> list[str]:
    """Layout problems of ``fig`` (a matplotlib ``Figure``), one line each; ``[]`` when it
    passes. The figure is drawn (its layout engine runs) on its own canvas first."""
    from matplotlib.figure import Figure

    if not isinstance(fig, Figure):
        raise TypeError(f"fig: expected a matplotlib Figure, got {type(fig).__name__}")
    if not hasattr(fig.canvas, "get_renderer"):
        # a Figure built without pyplot, or one pyplot has closed: draw it with Agg
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    fbox = fig.bbox
    problems: list[str] = []

    def check(role: str, t: Any, box: Any, where: str) -> None:
        if t is None or not t.get_visible() or not t.get_text().strip():
            return
        bb = t.get_window_extent(renderer)
        if not _inside(bb, box):
            text = " ".join(t.get_text().split())
            if len(text) > 60:
                text = text[:59] + "…"
            problems.append(
                f"{role} {text!r} reaches outside the {where} "
                f"(text x {bb.x0:.0f}–{bb.x1:.0f}, y {bb.y0:.0f}–{bb.y1:.0f} px; {where} "
                f"x {box.x0:.0f}–{box.x1:.0f}, y {box.y0:.0f}–{box.y1:.0f} px)"
            )

    suptitle = getattr(fig, "_suptitle", None)
    check("suptitle", suptitle, fbox, "figure")
    for t in fig.texts:
        if t is not suptitle:  # the suptitle is one of the figure's texts
            check("figure text", t, fbox, "figure")
    for leg in fig.legends:
        for t in leg.get_texts():
            check("legend entry", t, fbox, "figure")
    for i, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        name = f"axes {i}" + (f" ({ax.get_title()[:30]!r})" if ax.get_title() else "")
        for role, t in _texts_of_axes(ax):
            check(f"{name}: {role}", t, fbox, "figure")
        abox = ax.get_window_extent(renderer)
        for t in ax.texts:  # annotations and ax.text labels belong inside their axes
            check(f"{name}: annotation", t, abox, "axes")
        if not ax.axison:
            continue
        for axis, label in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            if not axis.get_visible():
                continue
            cats = _categories(axis)
            need = 2 if cats is None else min(2, cats)
            have = _labelled_ticks(axis)
            if have < need:
                problems.append(
                    f"{name}: {label} axis has {have} labelled tick(s) in view (need {need}; "
                    f"scale {axis.get_scale()}, view "
                    f"{tuple(float(f'{v:.4g}') for v in axis.get_view_interval())})"
                )
    return problems
