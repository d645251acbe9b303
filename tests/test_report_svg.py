"""harmbal.reporting.svg: the report's figures rendered once each, two at a
time where the machine allows, with ids that depend only on the drawing.

Oracles: the serial rendering (the forked one must equal it byte for byte),
a forked child that fails (its figures are then made here), and the SVG's
own id references (every ``url(#…)`` and ``href="#…"`` names an id of the
same figure).
"""

import re
from functools import partial

import pytest

from harmbal.reporting import svg


def _figure(title: str, values):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(values, marker="o")
    ax.set_title(title)
    return fig


def _makers(count: int):
    return [(partial(_figure, f"figure {i}", [0, i, 2 * i]), i + 1, f"f{i}") for i in range(count)]


def test_forked_rendering_equals_serial_rendering(monkeypatch):
    if not svg.can_fork():
        pytest.skip("no fork or one CPU here: figures_svg renders serially")
    forked = svg._complete(_makers(5), svg._shared(_makers(5)))
    monkeypatch.setenv(svg.SERIAL_ENV, "1")
    assert svg.figures_svg(_makers(5)) == forked


def test_without_the_commands_worker_nothing_is_forked(monkeypatch):
    # hb.report from Python (a notebook kernel) must never fork its process.
    monkeypatch.setattr(svg.os, "fork", lambda: pytest.fail("forked"))
    assert len(svg.figures_svg(_makers(3))) == 3


def test_a_failing_child_is_made_good_here(monkeypatch):
    if not svg.can_fork():
        pytest.skip("no fork or one CPU here")
    monkeypatch.setenv(svg.SERIAL_ENV, "1")
    serial = svg.figures_svg(_makers(4))
    monkeypatch.delenv(svg.SERIAL_ENV)
    real = svg.made_svg
    parent = __import__("os").getpid()

    def broken_in_child(make, number):
        if __import__("os").getpid() != parent:
            raise RuntimeError("the child fails")
        return real(make, number)

    monkeypatch.setattr(svg, "made_svg", broken_in_child)
    assert svg._complete(_makers(4), svg._shared(_makers(4))) == serial


def test_ids_are_renamed_in_order_and_every_reference_resolves():
    text = svg.made_svg(partial(_figure, "ids", [0, 1, 3]), 7)
    ids = re.findall(r'id="([a-z]7-\d+)"', text)
    assert ids and ids == [f"{i[0]}7-{n}" for n, i in enumerate(ids)]
    assert not re.search(r'id="[a-z][0-9a-f]{10}"', text)
    references = set(re.findall(r'(?:url\(#|href="#)([^)"]+)', text))
    assert references and references <= set(re.findall(r'id="([^"]+)"', text))


def test_the_same_drawing_gets_the_same_ids_whatever_the_float_noise():
    # Two clip rectangles that differ in the last bit hash differently in matplotlib; renamed in order they agree.
    a = svg.canonical_ids('<svg><clipPath id="p0123456789"/><g clip-path="url(#p0123456789)"/></svg>', 3)
    b = svg.canonical_ids('<svg><clipPath id="pabcdefabcd"/><g clip-path="url(#pabcdefabcd)"/></svg>', 3)
    assert a == b == '<svg><clipPath id="p3-0"/><g clip-path="url(#p3-0)"/></svg>'


def test_the_work_is_shared_by_cost():
    figures = [(None, 1, "stars"), (None, 2, "spectrum"), (None, 3, "traces"), (None, 4, "locus"), (None, 5, "x")]
    child = set(svg._half(figures))
    cost = {i: svg.COSTS.get(f[2], 1.0) for i, f in enumerate(figures)}
    mine = sum(cost[i] for i in cost if i not in child)
    theirs = sum(cost[i] for i in child)
    assert child and abs(mine - theirs) <= max(cost.values())


def test_the_early_worker_makes_the_same_svg(monkeypatch):
    if not svg.can_fork():
        pytest.skip("no fork or one CPU here")
    monkeypatch.setenv(svg.SERIAL_ENV, "1")
    serial = svg.figures_svg(_makers(5))
    monkeypatch.delenv(svg.SERIAL_ENV)
    assert svg.start_worker()
    assert not svg.start_worker()  # one waits already
    assert svg.figures_svg(_makers(5)) == serial
    assert svg._worker is None  # used once


def test_figures_the_worker_cannot_take_are_made_here(monkeypatch):
    if not svg.can_fork():
        pytest.skip("no fork or one CPU here")
    monkeypatch.setenv(svg.SERIAL_ENV, "1")
    serial = svg.figures_svg(_makers(3))
    monkeypatch.delenv(svg.SERIAL_ENV)
    assert svg.start_worker()
    unpicklable = [(lambda make=make: make(), number, name) for make, number, name in _makers(3)]
    assert svg.figures_svg(unpicklable) == serial


def test_an_unused_worker_leaves_when_told_nothing():
    import os

    if not svg.can_fork():
        pytest.skip("no fork or one CPU here")
    assert svg.start_worker()
    pid, inbox, outbox = svg._take_worker()
    inbox.close()  # no report: end of input
    assert outbox.read() == b""
    _, status = os.waitpid(pid, 0)
    assert status == 0
    outbox.close()
