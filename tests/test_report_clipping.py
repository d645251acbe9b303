"""No text is cut off in any figure of the report.

Every figure that :func:`harmbal.report` puts on the page is caught as the
page is made, drawn again on an Agg canvas (the same font metrics as the
SVG's), and every text artist that the draw actually renders (non-empty,
visible) must lie inside the figure: its window extent within ``fig.bbox``.
The engines cover the figure kinds: an inline three without and with gas
(pressure, torque, speed fluctuation), a cross-plane V8 at two speeds, a
single cylinder, a lever balancer (mechanism sketch) and a V8 sweep of three
speeds (Campbell maps with their colour bars).
"""

from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.reporting import html

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"
SCENES = ["tractor-3cyl", "v8-cross-plane", "single", "tractor-3cyl-gas", "lever-single"]
#: A rendered text may touch the figure's edge by this much [px] (anti-aliasing of the extent).
EDGE = 0.5
#: Room for a browser's font: each text must fit with its extent grown by this factor about its
#: centre (the SVG keeps text as text, and a browser without DejaVu Sans draws it a little wider).
FONT_SLACK = 1.04


def _scene(name: str):
    if name == "v8-sweep":
        speeds = np.array([1000.0, 3000.0, 6000.0]) * np.pi / 30
        return hb.load_scene(ENGINES / "v8-cross-plane.toml").with_speeds(speeds)
    return hb.load_scene(ENGINES / f"{name}.toml")


def report_figures(scene, monkeypatch) -> list:
    """(name, figure) of every figure the report of ``scene`` makes, made
    with the report's style."""
    from harmbal.reporting.svg import report_style

    caught = []
    original = html._Page.figure

    def catch(self, make, caption, name):
        with report_style():
            caught.append((name, make()))
        return original(self, make, caption, name)

    monkeypatch.setattr(html._Page, "figure", catch)
    hb.report(hb.analyse(scene))
    return caught


def drawn_texts(fig) -> list:
    """Every Text the figure's draw renders: (text artist, window extent)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    canvas = FigureCanvasAgg(fig)
    seen = []
    original = Text.draw

    def record(self, renderer):
        if self.get_visible() and self.get_text().strip():
            seen.append(self)
        return original(self, renderer)

    Text.draw = record
    try:
        canvas.draw()
    finally:
        Text.draw = original
    renderer = canvas.get_renderer()
    return [(t, t.get_window_extent(renderer)) for t in seen]


def outside(fig) -> list[str]:
    """The texts of ``fig`` whose extent leaves the figure, with where."""
    box = fig.bbox
    found = []
    for text, extent in drawn_texts(fig):
        extent = extent.expanded(FONT_SLACK, FONT_SLACK)
        if (extent.x0 < box.x0 - EDGE or extent.y0 < box.y0 - EDGE or extent.x1 > box.x1 + EDGE
                or extent.y1 > box.y1 + EDGE):
            found.append(f"{text.get_text()!r}: {extent.bounds} outside {box.bounds}")
    return found


@pytest.mark.parametrize("name", SCENES + ["v8-sweep"])
def test_no_text_is_clipped_in_any_figure(name, monkeypatch):
    figures = report_figures(_scene(name), monkeypatch)
    assert figures
    problems = {figure: outside(fig) for figure, fig in figures}
    assert not any(problems.values()), {k: v for k, v in problems.items() if v}


def test_the_check_finds_a_clipped_title():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2))
    fig.add_subplot().set_title("a title far too long to fit in a figure three inches wide " * 2)
    assert outside(fig)
    fig = Figure(figsize=(3, 2), layout="constrained")
    fig.add_subplot().set_title("short")
    assert not outside(fig)
