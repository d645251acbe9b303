"""Text and HTML summaries of balancer designs, for ``repr`` in a console and
``_repr_html_`` in a notebook.

:class:`~harmbal.balance.design.Design` and
:class:`~harmbal.balance.lever.LeverDesign` show what was designed (the
elements with their unbalance [kg mm] and angle [deg], or the balance weight)
and what remains (per targeted order and component the value without the new
elements and the predicted residual [N or N m], the components made worse).
The same summary of a design Dataset (``Design.dataset``, an archive's
``/design``) is ``ds.harmbal.summary()`` (:mod:`harmbal.accessor`).

Every text that goes into HTML is escaped with :func:`html.escape`: the names
of scenes, elements and levers come from the user's files.
"""

from __future__ import annotations

import html

import numpy as np

from ..orders.spectrum import phase_degrees
from .verify import CHECKED_ORDER, describe_component

#: How a phasor's phase is given: at θ = 0, from +z in the direction of rotation.
ANGLE_NOTE = "angle at θ = 0 from +z in the direction of rotation"


def escape(text) -> str:
    """``text`` as HTML text: ``&``, ``<``, ``>`` and quotes escaped."""
    return html.escape(str(text), quote=True)


def html_table(header: list[str], rows: list[list], text_columns: int = 1) -> str:
    """An HTML table of escaped cells; the first ``text_columns`` columns
    left-aligned, the others (numbers) right-aligned."""
    def cells(values, tag: str) -> str:
        return "".join(f'<{tag} style="text-align:{"left" if i < text_columns else "right"}">{escape(v)}</{tag}>'
                       for i, v in enumerate(values))

    body = "".join(f"<tr>{cells(row, 'td')}</tr>" for row in rows)
    return f"<table><thead><tr>{cells(header, 'th')}</tr></thead><tbody>{body}</tbody></table>"


def html_list(items) -> str:
    """An HTML bullet list of escaped items."""
    return "<ul>" + "".join(f"<li>{escape(item)}</li>" for item in items) + "</ul>"


def html_block(title: str, parts: list[str]) -> str:
    """A summary: the escaped ``title`` in bold above ``parts`` (HTML already)."""
    return f'<div class="harmbal-summary"><p><strong>{escape(title)}</strong></p>{"".join(parts)}</div>'


def phasor_text(value: complex, units: str) -> str:
    """A phasor as amplitude and phase, e.g. ``1726.9 N at 0.0°``; ``0 N``
    (no phase) when it is exactly 0."""
    if value == 0:
        return f"0 {units}"
    return f"{abs(value):.5g} {units} at {phase_degrees(value, 1):.1f}°"


def _design_title(ds, name: str) -> str:
    engine = ds.attrs.get("engine", name)
    source = f" (from {engine})" if engine != name else ""
    state = "feasible" if ds.attrs.get("feasible", "yes") == "yes" else "targets left"
    return (f"Design {name}{source}: orders {', '.join(str(k) for k in ds['order'].values)} at "
            f"{float(ds['rpm']):.6g} rpm; cancel {', '.join(ds.attrs.get('cancel', '').split())}; objective "
            f"{ds.attrs.get('objective', '')}: {state}")


def _element_rows(ds) -> list[list[str]]:
    """Per designed unknown: its name, unbalance [kg mm] and angle [deg] in [0, 360)."""
    return [[str(label), f"{u * 1e3:.6g}", f"{np.degrees(angle) % 360:.2f}"]
            for label, u, angle in zip(ds["element"].values, ds["unbalance"].values, ds["unbalance_angle"].values)]


def _target_rows(ds) -> list[list[str]]:
    """Per targeted order and component: what it is, the value without the
    new elements, the predicted residual and whether it is cancelled."""
    rows = []
    for i, k in enumerate(ds["order"].values):
        for j, component in enumerate(ds["component"].values):
            if not ds["targeted"].values[i, j]:
                continue
            units = str(ds["component_units"].values[j])
            rows.append([describe_component(int(k), str(component)),
                         phasor_text(complex(ds["before"].values[i, j]), units),
                         phasor_text(complex(ds["predicted"].values[i, j]), units),
                         "cancelled" if ds["cancelled"].values[i, j] else "LEFT"])
    return rows


def _checked_orders(ds) -> str:
    orders = ds[CHECKED_ORDER].values if CHECKED_ORDER in ds.coords else np.array([])
    return f"orders {orders.min()}–{orders.max()}" if orders.size else "the orders checked"


def _worsened_line(ds, worsened) -> str:
    if worsened:
        return "Made worse (not targeted):"
    return f"Nothing else made worse by the new elements ({_checked_orders(ds)}, every component)."


def design_text(ds, name: str, messages=(), worsened=()) -> str:
    """The text summary of a design.

    Parameters
    ----------
    ds : xarray.Dataset
        ``Design.dataset`` (dims ``order``, ``component``, ``element``).
    name : str
        The designed scene's ``engine.name``.
    messages, worsened : sequence of str
        ``Design.messages`` (what is left, in words) and ``Design.worsened``
        (components made worse, one sentence each).

    Returns
    -------
    str
        The title, the elements (unbalance [kg mm], angle [deg]), the
        targets (value without the new elements → predicted residual [N or
        N m]), what is made worse, and the messages.
    """
    lines = [_design_title(ds, name), f"Elements (unbalance = mass × radius; {ANGLE_NOTE}):"]
    lines += [f"  {label:<34} {u:>10} kg mm at {angle:>6}°" for label, u, angle in _element_rows(ds)]
    lines.append("Targets (without the new elements → predicted residual):")
    lines += [f"  {what:<34} {was:>24} → {now:<24} {state}" for what, was, now, state in _target_rows(ds)]
    lines.append(_worsened_line(ds, worsened))
    lines += [f"  {w}" for w in worsened] + [f"! {m}" for m in messages]
    return "\n".join(lines)


def design_html(ds, name: str, messages=(), worsened=()) -> str:
    """:func:`design_text` as HTML (tables of the elements and the targets)."""
    parts = [f"<p>Elements (unbalance = mass × radius; {escape(ANGLE_NOTE)}):</p>",
             html_table(["element", "unbalance [kg mm]", "angle [deg]"], _element_rows(ds)),
             "<p>Targets:</p>",
             html_table(["order and component", "without the new elements", "predicted residual", "result"],
                        _target_rows(ds)),
             f"<p>{escape(_worsened_line(ds, worsened))}</p>"]
    if worsened:
        parts.append(html_list(worsened))
    if messages:
        parts += ["<p>What is left:</p>", html_list(messages)]
    return html_block(_design_title(ds, name), parts)


def _lever_unit(result) -> str:
    """The criterion's unit: the signals' (N, N m), squared for the "orders" objective."""
    unit = " or ".join(sorted({str(u) for u in result.breakdown["signal_units"].values}))
    if result.request.objective != "orders":
        return unit
    return f"{unit}²" if unit == "N" else f"({unit})²"


def _lever_title(result) -> str:
    request = result.request
    return (f"LeverDesign of {result.scene.name}: balance weight of lever balancer {result.lever!r}, objective "
            f"{request.objective} of {', '.join(request.signals)} at {result.speed * 30 / np.pi:.6g} rpm "
            f"(method {result.method})")


def _weight_rows(result) -> list[list[str]]:
    """Start and result: mass [kg], x_G, y_G [mm] in the coupler's frame and the criterion."""
    found = "end point" if result.method == "compass" else "optimum"
    return [[label, f"{m:.6g}", f"{x * 1e3:.6g}", f"{y * 1e3:.6g}", f"{value:.8g}"]
            for label, (m, x, y), value in (("start", result.start, result.criterion_start),
                                            (found, result.weight, result.criterion))]


def _lever_check(result) -> str:
    state = "verified" if result.verified else "NOT verified"
    return (f"Exact model of the output scene: criterion {result.exact_criterion:.10g} {_lever_unit(result)} "
            f"(|Δ| {abs(result.exact_criterion - result.criterion):.2g}, tolerance {result.tolerance:.2g}): {state}")


def lever_text(result) -> str:
    """The text summary of a :class:`~harmbal.balance.lever.LeverDesign`:
    the weight (mass [kg], CG [mm]) and criterion at the start and found,
    and the exact model's check."""
    header = ["", "mass [kg]", "x_G [mm]", "y_G [mm]", f"criterion [{_lever_unit(result)}]"]
    lines = [_lever_title(result), "  " + f"{header[0]:<10}" + "".join(f"{h:>14}" for h in header[1:4])
             + f"{header[4]:>22}"]
    lines += ["  " + f"{row[0]:<10}" + "".join(f"{v:>14}" for v in row[1:4]) + f"{row[4]:>22}"
              for row in _weight_rows(result)]
    lines += [_lever_check(result)] + [f"! {m}" for m in result.messages]
    return "\n".join(lines)


def lever_html(result) -> str:
    """:func:`lever_text` as HTML."""
    parts = [html_table(["", "mass [kg]", "x_G [mm]", "y_G [mm]", f"criterion [{_lever_unit(result)}]"],
                        _weight_rows(result)),
             f"<p>{escape(_lever_check(result))}</p>"]
    if result.messages:
        parts.append(html_list(result.messages))
    return html_block(_lever_title(result), parts)
