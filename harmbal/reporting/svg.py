"""The report's figures as inline SVG: each made and rendered once and,
for the ``harmbal report`` command, two at a time.

Making and drawing the figures (matplotlib's import, the layout, the SVG) is
most of what a report costs once the analysis is done (docs/performance.md,
"Report"), and the figures are independent. The report hands
:func:`figures_svg` a maker per figure (a function and its Datasets):

* if :func:`start_worker` was called earlier (only ``harmbal report`` does,
  before it analyses the scene, in a process of its own), the figures go to
  that process, which has imported matplotlib meanwhile, and it makes them in
  two processes (itself and one child, about half each by their usual cost);
* otherwise (``hb.report`` from Python, a notebook: a process harmbal does
  not own must never be forked) they are made here, one after the other.

A helper writes its SVG texts back and exits; whatever it fails to deliver
is made here, so the page is the same either way: a figure's SVG depends
only on its maker and its number. Without ``os.fork``, with one CPU, or with
``HARMBAL_REPORT_SERIAL=1``, no worker is started.
"""

from __future__ import annotations

import io
import os
import pickle
import re
import sys
import tempfile

#: Set this environment variable to "1" to make every figure in this process (no fork).
SERIAL_ENV = "HARMBAL_REPORT_SERIAL"

#: The usual cost of a figure by its name, relative to a figure of one or two axes (for sharing them out).
COSTS = {"stars": 3.0, "pressure": 1.5, "spectrum": 1.3, "traces": 1.3, "main-bearings": 2.0, "crank-pin": 1.5,
         "mechanism": 1.5, "lever": 1.3}

#: The ids matplotlib's SVG writer hashes from what they stand for (a clip rectangle's float corners, a
#: marker's path): a letter and ten hexadecimal digits.
_HASHED_ID = re.compile(r'id="([a-z])([0-9a-f]{10})"')

#: The process started by :func:`start_worker` and not used yet: (pid, its inbox, its outbox).
_worker: tuple | None = None


def figure_svg(fig, number: int) -> str:
    """A figure as an inline ``<svg>`` element: deterministic, text as text,
    ids unique on the page (:func:`canonical_ids`)."""
    import matplotlib

    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": f"harmbal-{number}", "svg.fonttype": "none"}):
        fig.savefig(buffer, format="svg", metadata={"Date": None})
    text = buffer.getvalue()
    return canonical_ids(text[text.index("<svg"):], number)


def made_svg(make, number: int) -> str:
    """Make a figure with the report's style (:func:`report_style`) and
    render it (:func:`figure_svg`)."""
    with report_style():
        return figure_svg(make(), number)


def report_style():
    """The matplotlib settings the report's figures are made with: axes
    titles at a fixed height above the axes (none of the report's axes has
    ticks on top), which spares matplotlib measuring every tick label again
    to place each title (a tenth of the drawing); text drawn literally (no
    mathtext)."""
    import matplotlib

    # text.parse_math off: names and labels from the scene are drawn as written, "$" and "\\" included
    # (matplotlib would read "a $\\foo$" as mathtext and fail); harmbal's own labels use no mathtext.
    return matplotlib.rc_context({"axes.titley": 1.0, "text.parse_math": False})


def canonical_ids(svg: str, number: int) -> str:
    """``svg`` with its hashed ids (``p3c1f…``) renamed in order of first
    appearance to ``<letter><number>-<i>`` (``p4-0``, ``p4-1``, …).

    A clip rectangle's id hashes its corners as floats, so a layout that
    differs in the last bit (the same figure from data that round-tripped
    through an archive) would name the same clip differently; in order of
    appearance the names depend only on the drawing. ``number`` keeps them
    unique on the page.
    """
    names: dict[str, str] = {}
    for letter, digest in _HASHED_ID.findall(svg):
        names.setdefault(letter + digest, f"{letter}{number}-{len(names)}")
    if not names:
        return svg
    pattern = re.compile("(?<=[\"#])(" + "|".join(map(re.escape, names)) + ")(?=[\")])")
    return pattern.sub(lambda m: names[m.group(1)], svg)


def figures_svg(figures: list) -> list[str]:
    """The SVG of each of ``figures``, a list of (maker, number, name).

    Returns
    -------
    list of str
        In the order given, the same as ``[made_svg(make, number) for make,
        number, _ in figures]`` (made by the worker of :func:`start_worker`,
        where one was started).
    """
    worker = _take_worker()
    found = _ask(worker, figures) if worker is not None and figures else None
    return _complete(figures, found or {})


def start_worker() -> bool:
    """Fork, now, the process that will make the next report's figures.

    It imports matplotlib and loads its font while the caller analyses the
    scene, then waits for :func:`figures_svg` to send it the figures (and
    exits when this process closes the pipe without sending any). Call it
    once xarray is imported (the figures' Datasets travel pickled), as
    ``harmbal report`` does.

    Returns
    -------
    bool
        Whether a worker was started (Linux, two or more CPUs, not
        ``HARMBAL_REPORT_SERIAL=1``, none waiting already).
    """
    global _worker
    if _worker is not None or not can_fork():
        return False
    inbox_r, inbox_w = os.pipe()
    outbox_r, outbox_w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(inbox_w)
        os.close(outbox_r)
        _serve(inbox_r, outbox_w)  # never returns
    os.close(inbox_r)
    os.close(outbox_w)
    _worker = (pid, os.fdopen(inbox_w, "wb"), os.fdopen(outbox_r, "rb"))
    return True


def _serve(inbox: int, outbox: int) -> None:
    """The worker: prepare, read the figures, make them (in two processes), write the SVGs, exit."""
    status = 1
    try:
        _prepare()
        with os.fdopen(inbox, "rb") as source:
            try:
                figures = pickle.load(source)
            except EOFError:  # no report came: nothing to do
                figures = None
        if figures is not None:
            found = _shared(figures) if len(figures) > 1 else {}
            found.update({i: made_svg(*figures[i][:2]) for i in range(len(figures)) if i not in found})
            with os.fdopen(outbox, "wb") as sink:
                pickle.dump(found, sink)
        status = 0
    finally:
        os._exit(status)


def _take_worker():
    """The waiting worker, if any (each serves one report)."""
    global _worker
    worker, _worker = _worker, None
    return worker


def _ask(worker, figures: list) -> dict | None:
    """Send ``figures`` to ``worker`` and read its SVG texts; None if that fails."""
    pid, inbox, outbox = worker
    found = None
    try:
        with inbox:
            pickle.dump(figures, inbox)
        found = pickle.load(outbox)
    except Exception:  # a maker that does not pickle, a worker that died: make them here
        found = None
    finally:
        outbox.close()
        _reap(pid)
    return found if isinstance(found, dict) else None


def _reap(pid: int) -> None:
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass


def _complete(figures: list, found: dict) -> list[str]:
    """The SVGs in order: those delivered, and the rest made here."""
    return [str(found[i]) if i in found else made_svg(make, number)
            for i, (make, number, _) in enumerate(figures)]


def _shared(figures: list) -> dict[int, str]:
    """The SVGs of ``figures``, about half made in a forked child (:func:`_half`) and the others here."""
    theirs = set(_half(figures))
    out: dict[int, str] = {}
    with tempfile.TemporaryFile() as spool:
        pid = os.fork()
        if pid == 0:  # the child: make its share, write it, leave without running the parent's cleanup
            status = 1
            try:
                pickle.dump({i: made_svg(*figures[i][:2]) for i in sorted(theirs)}, spool)
                spool.flush()
                status = 0
            finally:
                os._exit(status)
        for i, (make, number, _) in enumerate(figures):
            if i not in theirs:
                out[i] = made_svg(make, number)
        out.update(_collect(pid, spool))
    return out


def _prepare() -> None:
    """Import what every figure needs (matplotlib's figure and SVG backend)
    and load the default font."""
    import matplotlib.backends.backend_svg  # noqa: F401
    import matplotlib.figure  # noqa: F401
    from matplotlib import font_manager

    font_manager.get_font(font_manager.findfont(font_manager.FontProperties()))


def can_fork() -> bool:
    """Linux, fork available, two or more CPUs for this process, not switched off."""
    if os.environ.get(SERIAL_ENV) == "1" or not sys.platform.startswith("linux") or not hasattr(os, "fork"):
        return False
    try:
        return len(os.sched_getaffinity(0)) > 1
    except (AttributeError, OSError):
        return (os.cpu_count() or 1) > 1


def _half(figures: list) -> list[int]:
    """Indices of about half the work (:data:`COSTS`) for the child: the
    dearest first, each to the lighter side."""
    order = sorted(range(len(figures)), key=lambda i: -COSTS.get(figures[i][2], 1.0))
    sides: tuple[list[int], list[int]] = ([], [])
    loads = [0.0, 0.0]
    for i in order:
        side = 0 if loads[0] <= loads[1] else 1
        sides[side].append(i)
        loads[side] += COSTS.get(figures[i][2], 1.0)
    return sides[1]


def _collect(pid: int, spool) -> dict[int, str]:
    """The child's SVG texts, or nothing if it failed."""
    _, status = os.waitpid(pid, 0)
    if status != 0:
        return {}
    spool.seek(0)
    try:
        found = pickle.load(spool)
    except Exception:  # a truncated or empty file: make those figures here
        return {}
    return {int(i): str(text) for i, text in found.items()} if isinstance(found, dict) else {}
