"""Every report figure passes the programmatic layout check (issue 27): no text outside the
figure (a cut title), no annotation spilling out of its axes, at least two labelled ticks per
axis (a log axis with one label gives no scale).

The figures are rendered from a small suite run through the Python API — the quick suite's
scenarios plus a fault scenario (its title names the fault), shortened, with two attitude and
two SE(3) controllers, so the Pareto figures have coinciding markers — and each one is checked
just before it is saved. The checker itself is tested on figures built to fail.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from benchmarks import report  # noqa: E402
from benchmarks.figure_layout import layout_problems  # noqa: E402
from benchmarks.runner import run_suite  # noqa: E402
from benchmarks.scenarios import SCENARIOS, get_suite  # noqa: E402

CONTROLLERS = ("geometric-pd-log", "geometric-pd-trace", "se3-tracking", "bullo-murray-pd")


@pytest.fixture(scope="module")
def small_result():
    scenarios = [*get_suite("quick").scenarios, SCENARIOS["fault-gimbal-stuck-slew-90"]]
    # a quarter of each run: the panels, titles and axes are those of the full report
    short = [s.with_duration(max(0.25 * s.duration, 80.0)) for s in scenarios]
    return run_suite(short, CONTROLLERS, executor="serial", progress=False)


def test_every_report_figure_passes_the_layout_check(small_result, tmp_path, monkeypatch):
    problems: dict[str, list[str]] = {}

    def checked(fig, path):  # the check draws the figure as savefig would; no PNG needed
        problems[path.name] = layout_problems(fig)
        plt.close(fig)
        return path

    monkeypatch.setattr(report, "save_png", checked)
    figs = report.write_figures(small_result, tmp_path)
    names = {p.name for p in figs.values()}
    assert "overview.png" in names and "fast-slew-rate-limited-pareto.png" in names
    assert "fault-gimbal-stuck-slew-90.png" in names and "proximity-approach-pareto.png" in names
    assert set(problems) == names
    bad = {k: v for k, v in problems.items() if v}
    assert not bad, "\n".join(f"{k}:\n  " + "\n  ".join(v) for k, v in bad.items())


def test_the_check_finds_a_cut_title():
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1])
    fig.suptitle("a scenario description far too long to fit on one line of this figure " * 2)
    try:
        assert any("suptitle" in p and "outside the figure" in p for p in layout_problems(fig))
    finally:
        plt.close(fig)


def test_the_check_finds_a_label_spilling_out_of_its_axes():
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1])
    ax.annotate("3 overlapping", (1, 1), xytext=(10, 8), textcoords="offset points")
    try:
        assert any("annotation" in p and "outside the axes" in p for p in layout_problems(fig))
    finally:
        plt.close(fig)


def test_the_check_finds_a_single_labelled_tick():
    from matplotlib.ticker import NullFormatter

    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([20.0, 80.0], [1.0, 2.0])
    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlim(15.0, 90.0)  # no power of ten in view: one or no labelled major tick
    try:
        assert any("x axis has" in p for p in layout_problems(fig))
    finally:
        plt.close(fig)


def test_the_report_scale_keeps_two_labels_on_a_short_log_axis():
    fig, ax = plt.subplots(figsize=(4, 3))
    values = [0.0052, 0.099]  # the slew-179 Pareto axis that showed a single label
    ax.plot(values, [1.0, 2.0], "o")
    assert report._scale_axis(ax, values, "x") == " (log)"
    try:
        assert layout_problems(fig) == []
    finally:
        plt.close(fig)


def test_coinciding_pareto_markers_are_not_moved(small_result, tmp_path, monkeypatch):
    """Markers of equal value stay at that value (no sideways jitter on a ratio axis)."""
    scenario = next(s for s in small_result.scenarios if s.name == "fast-slew-rate-limited")
    drawn: list = []
    save = report.save_png

    def keep(fig, path):  # checked before saving, which closes the figure
        ax = fig.axes[1]
        lines = ax.get_lines()
        drawn.append((fig, [tuple(ln.get_xdata()) for ln in lines],
                      [ln.get_transform() == ax.transData for ln in lines],
                      [ln.get_linestyle() for ln in lines], layout_problems(fig)))  # fmt: skip
        return save(fig, path)

    monkeypatch.setattr(report, "save_png", keep)
    report.write_pareto_figure(small_result, scenario, tmp_path / "p.png")
    pts, _, _ = report._pareto_points(small_result, scenario)
    use = {round(v[2], 12) for v in pts.values()}
    _, xdata, on_data, styles, problems = drawn[0]
    for x, plain, ls in zip(xdata, on_data, styles, strict=True):
        if len(x) == 1 and ls in ("None", "none", ""):  # a marker, not a line
            assert round(float(x[0]), 12) in use
            assert plain  # drawn in data coordinates: no offset transform
    assert problems == []


def test_layout_problems_wants_a_figure():
    with pytest.raises(TypeError, match="^fig"):
        layout_problems("figure.png")
