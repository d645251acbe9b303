"""The report's section "Powertrain on its mounts" (``/mounts`` of
:func:`harmbal.analyse`, docs/mounts.md): the statics, the six rigid-body
modes with their kinetic-energy distribution as a heat table, the torque
roll axis, and the forces transmitted into the frame per order and speed,
with the section's figures.

Round-off is never drawn as a result. An order the engine does not excite
(:func:`zero_orders`: its shaking force, moment and roll are zero to
round-off in ``/orders``, the cylinders' phasors cancel, or its transmitted
force is at most :data:`harmbal.reporting.mount_tables.ZERO_SHARE` of the
largest) is left out of the figures and tables and named in a note; a value
of a shown order at that share or below is drawn blank and printed 0.

Like :mod:`harmbal.reporting.plots`, the figures use
:class:`matplotlib.figure.Figure` directly and import matplotlib only when
called; :func:`mounts_section` hands them to the report as makers.
"""

from __future__ import annotations

import html
import math
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from ..orders.spectrum import ZERO
from .mount_tables import TOP_ORDERS, ZERO_SHARE
from .plots import OKABE_ITO, fitted, series_style, suptitle
from .review import order_ranges

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: The static load cases as the page names them (``/mounts`` dim ``case``).
CASE_NAMES = {"weight": "weight", "weight+mean_torque": "weight + mean torque reaction (gas)",
              "weight+full_load": "weight + full-load torque reaction"}
#: Colour of the energy heat table's cells (Okabe–Ito blue) as RGB: the cell's opacity is the share.
HEAT_RGB = (0, 114, 178)
#: Share above which a heat cell's text turns white (legible on the dark blue).
HEAT_LIGHT_TEXT = 0.55
#: The Campbell map's colours run over this many decades below the largest total force.
MAP_DECADES = 6
#: Style of a frequency outside the design band or a share below the design's decoupling.
_OUTSIDE = ' style="color:#a33b00;font-weight:600"'
_TEXT = ' class="text"'


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _row(cells: list[str], tag: str = "td", text_columns: int = 1) -> str:
    """A table row of already formatted cell texts (the first ``text_columns`` left-aligned)."""
    return "<tr>" + "".join(f"<{tag}{_TEXT if i < text_columns else ''}>{_e(c)}</{tag}>"
                            for i, c in enumerate(cells)) + "</tr>"


def _table(header: list[str], rows: list[list[str]], text_columns: int = 1) -> str:
    body = "".join(_row(r, "td", text_columns) for r in rows)
    return f"<table><thead>{_row(header, 'th', text_columns)}</thead><tbody>{body}</tbody></table>"


def _clean(values) -> np.ndarray:
    """``values`` with round-off next to their largest (1e-12 of it) set to 0, and no −0."""
    values = np.asarray(values, dtype=float)
    return np.where(np.abs(values) <= 1e-12 * np.abs(values).max(initial=0.0), 0.0, values) + 0.0


def _fixed(value: float, digits: int) -> str:
    """``value`` with ``digits`` decimals, "0.000" rather than "-0.000" when it rounds to zero."""
    text = f"{value:.{digits}f}"
    return text.lstrip("-") if float(text) == 0 else text


def _speed_first(da, dims: tuple[str, ...]) -> np.ndarray:
    """``da``'s values over ``("speed", *dims)`` (a speed axis of 1 added for one speed)."""
    if "speed" not in da.dims:
        da = da.expand_dims("speed")
    return da.transpose("speed", *dims).values


def rpm_values(mounts: xr.Dataset) -> np.ndarray:
    """The crank speeds [rpm] of ``mounts`` (always 1-D)."""
    return np.atleast_1d(mounts["rpm"].values).astype(float)


def total_force_amplitude(mounts: xr.Dataset) -> np.ndarray:
    """|F| of the total force into the frame (speed, order): √Σ|F_c|² over the components, as
    ``transmitted_force_amplitude`` is per mount."""
    total = _speed_first(mounts["total_force"], ("order", "component"))
    return np.sqrt((np.abs(total) ** 2).sum(axis=-1))


def zero_orders(mounts: xr.Dataset, orders: xr.Dataset | None = None) -> np.ndarray:
    """Which orders of ``mounts`` are not drawn (bool, dim ``order``): those
    the engine does not excite (:func:`unexcited_orders`) and those whose
    largest transmitted force is at most :data:`ZERO_SHARE` of the largest of
    any order (the CLI's rule, :mod:`harmbal.reporting.mount_tables`)."""
    amplitude = _speed_first(mounts["transmitted_force_amplitude"], ("order", "mount"))
    peak = amplitude.max(axis=(0, 2))
    return (peak <= ZERO_SHARE * float(peak.max(initial=0.0))) | unexcited_orders(mounts, orders)


def unexcited_orders(mounts: xr.Dataset, orders: xr.Dataset | None) -> np.ndarray:
    """The orders of ``mounts`` whose shaking force, moment and roll
    ``orders`` (``/orders``) classes zero at every speed: round-off of
    cylinders whose phasors cancel (bool, dim ``order``; none without
    ``orders`` or its classes)."""
    k = mounts["order"].values
    names = [f"{g}_class" for g in ("force", "moment", "roll")]
    if orders is None or not all(name in orders for name in names):
        return np.zeros(k.size, dtype=bool)
    index = np.minimum(np.searchsorted(orders["order"].values, k), orders.sizes["order"] - 1)
    found = np.isclose(orders["order"].values[index], k, rtol=0, atol=1e-9)
    zero = found.copy()
    for name in names:
        code = orders[name].transpose("order", ...).values.reshape(orders.sizes["order"], -1)
        zero &= (code == ZERO).all(axis=1)[index]
    return zero


def largest_orders(mounts: xr.Dataset, zero: np.ndarray, count: int = TOP_ORDERS) -> list[int]:
    """Indices of the ``count`` orders with the largest transmitted force at
    any mount and speed (in order of the orders), zero orders left out."""
    peak = _speed_first(mounts["transmitted_force_amplitude"], ("order", "mount")).max(axis=(0, 2))
    ranked = [int(i) for i in np.argsort(-peak, kind="stable") if not zero[i]]
    return sorted(ranked[:count])


def design_band(request, mounts: xr.Dataset) -> tuple[float, float] | None:
    """The frequency band [Hz] a ``[mount_design]`` asks every mode to lie in
    (its default: 5 Hz to the idle firing frequency / √2), None without one."""
    if request is None:
        return None
    if request.frequency_band is not None:
        return (float(request.frequency_band[0]), float(request.frequency_band[1]))
    return (5.0, float(mounts.attrs["idle_firing_frequency"]) / math.sqrt(2))


# -- the page ------------------------------------------------------------------------------------

def mounts_section(page, scene, tree) -> None:
    """Add the section ``#mounts`` to ``page`` (the report's page: ``add``
    and ``figure``), for a tree with ``/mounts``."""
    ds = tree["mounts"].ds
    orders = tree["orders"].ds if "orders" in tree.children else None
    zero = zero_orders(ds, orders)
    request = scene.mount_design
    band = design_band(request, ds)
    page.add('<section id="mounts"><h2>Powertrain on its mounts</h2>'
             f'<p>{_e(_intro(ds))}</p><h3>Statics</h3>' + statics_html(ds, scene))
    page.add("<h3>Rigid-body modes</h3>" + modes_html(ds, band, None if request is None else request.decoupling))
    page.figure(partial(modes_figure, ds, zero=zero, band=band), "The rigid-body modes (horizontal lines) against "
                "the frequencies k·rpm/60 of the orders the engine excites over the speed range (the firing order "
                "bold, the idle firing frequency marked, circles where an order meets a mode)"
                + (", the [mount_design] band shaded." if band else "."), "mount-modes")
    forces_html(page, ds, zero, unexcited_orders(ds, orders))
    page.add("</section>")


def _intro(ds) -> str:
    idle = float(ds.attrs["idle_speed"]) * 30 / math.pi
    cg = np.asarray(ds.attrs["powertrain_cg"], dtype=float) * 1e3
    return (f"A rigid powertrain of {float(ds.attrs['powertrain_mass']):.5g} kg (centre of gravity at "
            f"({cg[0]:g}, {cg[1]:g}, {cg[2]:g}) mm) on {ds.sizes['mount']} mounts "
            f"({', '.join(str(m) for m in ds['mount'].values)}). Idle firing frequency "
            f"{float(ds.attrs['idle_firing_frequency']):.4g} Hz ({idle:.5g} rpm × firing order "
            f"{float(ds.attrs['firing_order']):g}). Forces are those of the mounts into the frame, in the engine "
            "frame (docs/mounts.md).")


def statics_html(ds, scene) -> str:
    """Per load case the roll angle and each mount's preload and deflection
    (one row per case and mount, the case and its roll spanning its rows)."""
    names = dict(CASE_NAMES)
    torque = None if scene.powertrain is None else scene.powertrain.drive_torque
    if torque is not None:
        names["weight+full_load"] = f"weight + full-load torque reaction ({torque:.5g} N m)"
    mounts = [str(m) for m in ds["mount"].values]
    preload = _clean(ds["preload"].transpose("case", "mount").values)
    deflection = _clean(ds["static_deflection"].transpose("case", "mount", "local").values) * 1e3
    head = ["load case", "roll angle [°]", "mount", "preload [N]", "δu [mm]", "δv [mm]", "δw [mm]"]
    header = "".join(f"<th{_TEXT if i in (0, 2) else ''}>{_e(h)}</th>" for i, h in enumerate(head))
    body = []
    for i, case in enumerate(str(c) for c in ds["case"].values):
        roll = _fixed(math.degrees(float(ds["static_roll"].sel(case=case))), 3)
        for j, mount in enumerate(mounts):
            first = (f'<td class="text" rowspan="{len(mounts)}">{_e(names.get(case, case))}</td>'
                     f'<td rowspan="{len(mounts)}">{roll}</td>') if j == 0 else ""
            cells = "".join(f"<td>{_fixed(d, 3)}</td>" for d in deflection[i, j])
            body.append(f'<tr>{first}<td class="text">{_e(mount)}</td><td>{preload[i, j]:.5g}</td>{cells}</tr>')
    return (f"<table class=\"mount-statics\"><thead><tr>{header}</tr></thead><tbody>{''.join(body)}</tbody></table>"
            '<p class="note">Roll: the rotation about the crank axis x (right-handed). Preload: the static load '
            "along each mount's preload axis, compression positive; δu, δv, δw: its deflection along its local "
            "axes. Every case's displacement of the centre of gravity is in the Dataset (static_displacement).</p>")


def _heat_cell(share: float, dominant: bool) -> str:
    """An energy share [%] as a cell whose background is as opaque as the share; the dominant one outlined."""
    share = min(max(share, 0.0), 1.0) + 0.0  # no "-0.000" from a share of −0
    r, g, b = HEAT_RGB
    style = f"background:rgba({r},{g},{b},{share:.3f});"
    if share > HEAT_LIGHT_TEXT:
        style += "color:#fff;"
    if dominant:
        style += "font-weight:700;outline:2px solid #1a1a1a;outline-offset:-2px;"
    mark = ' data-dominant="yes"' if dominant else ""
    return f'<td class="heat" style="{style}"{mark}>{100 * share + 0.0:.1f}</td>'


def modes_html(ds, band: tuple[float, float] | None, decoupling: float | None) -> str:
    """The modes table with the energy matrix as a heat table, then the torque roll axis."""
    damped = "damped_frequency" in ds
    dofs = [str(d) for d in ds["dof"].values]
    head = ["mode", "f [Hz]"] + (["f_d [Hz]", "ζ"] if damped else []) + ["f / f_idle firing", "dominant"]
    header = "".join(f"<th>{_e(h)}</th>" for h in head) + "".join(f"<th>{_e(d)} [%]</th>" for d in dofs)
    energy = ds["energy"].transpose("dof", "mode").values
    body = []
    for j, mode in enumerate(ds["mode"].values):
        f = float(ds["natural_frequency"][j])
        outside = band is not None and not band[0] <= f <= band[1]
        cells = [f"<td>{int(mode)}</td>", f"<td{_OUTSIDE if outside else ''}>{f:.3f}</td>"]
        if damped:
            cells += [f"<td>{float(ds['damped_frequency'][j]):.3f}</td>",
                      f"<td>{float(ds['damping_ratio'][j]):.3f}</td>"]
        share = float(ds["decoupling"][j])
        weak = decoupling is not None and share < decoupling
        cells += [f"<td>{float(ds['frequency_ratio_idle_firing'][j]):.3f}</td>",
                  f"<td{_TEXT}{_OUTSIDE if weak else ''}>{_e(ds['dominant_dof'].values[j])}</td>"]
        top = int(np.argmax(energy[:, j]))
        cells += [_heat_cell(float(energy[i, j]), i == top) for i in range(len(dofs))]
        body.append(f"<tr>{''.join(cells)}</tr>")
    table = (f'<table class="mount-modes" style="print-color-adjust:exact;-webkit-print-color-adjust:exact">'
             f"<thead><tr>{header}</tr></thead><tbody>{''.join(body)}</tbody></table>")
    return table + f'<p class="note">{_e(_modes_note(ds, band, decoupling))}</p>' + _tra_html(ds)


def _modes_note(ds, band, decoupling) -> str:
    note = ("Undamped natural frequencies f" + (", damped f_d with the modal damping ratio ζ" if "damped_frequency"
                                                 in ds else "")
            + f"; f_idle firing = {float(ds.attrs['idle_firing_frequency']):.4g} Hz. Energy: the share of each "
            "mode's kinetic energy in each degree of freedom at the centre of gravity (a row sums to 100 %; the "
            "cell's blue is the share, the dominant one outlined), the decoupling measure.")
    if band is not None:
        note += f" The [mount_design] asks every mode within {band[0]:.4g}–{band[1]:.4g} Hz" + (
            f" and at least {100 * decoupling:.4g} % of its energy in its dominant DOF" if decoupling else "") + ": "
        modes = ds["mode"].values
        outside = [int(m) for m, f in zip(modes, ds["natural_frequency"].values) if not band[0] <= f <= band[1]]
        weak = [int(m) for m, e in zip(modes, ds["decoupling"].values) if decoupling and e < decoupling]
        found = [f"{_modes(outside)} outside the band"] if outside else []
        found += [f"{_modes(weak)} below the share"] if weak else []
        note += "; ".join(found) + " (in colour)." if found else "every mode does."
    return note


def _modes(numbers: list[int]) -> str:
    return f"mode{'s' if len(numbers) > 1 else ''} {', '.join(map(str, numbers))}"


def _tra_html(ds) -> str:
    tra = _clean(ds["torque_roll_axis"].values)
    energy = ds["energy"].transpose("dof", "mode").values
    roll = list(ds["dof"].values).index("roll")
    mode = int(np.argmax(energy[roll]))
    centre = _clean(ds["elastic_centre"].values) * 1e3
    return (f'<p class="tra">Torque roll axis ({tra[0]:.4f}, {tra[1]:.4f}, {tra[2]:.4f}) (unit vector, engine '
            f"frame: the axis the powertrain turns about under a torque about the crank axis); the roll-dominant "
            f"mode is mode {int(ds['mode'].values[mode])} ({100 * energy[roll, mode]:.1f} % roll), its axis "
            f"<strong>{math.degrees(float(ds['tra_roll_mode_angle'])):.2f}°</strong> from the torque roll axis. "
            f"Elastic centre ({centre[0]:.1f}, {centre[1]:.1f}, {centre[2]:.1f}) mm from the centre of gravity.</p>")


def forces_html(page, ds, zero: np.ndarray, unexcited: np.ndarray) -> None:
    """The transmitted forces: the Campbell map of the total, the largest
    orders per mount against speed, their peaks, and the round-off note."""
    rpm = rpm_values(ds)
    page.add("<h3>Forces transmitted into the frame</h3>")
    if rpm.size >= 2:
        page.figure(partial(force_map_figure, ds, zero=zero), "Campbell map of the total force into the frame: the "
                    "amplitude √Σ|F_c|² of each order's sum of the mount forces against crank speed, "
                    f"{rpm.min():.6g} to {rpm.max():.6g} rpm, log colours over {MAP_DECADES} decades below the "
                    "largest (less drawn as the darkest); blank: not drawn, see the note below.", "mount-force-map")
    shown = largest_orders(ds, zero)
    if shown:
        page.figure(partial(mount_force_figure, ds, orders=tuple(shown)), "Force amplitude each mount transmits "
                    f"(√Σ|f_c|² over x, y, z) against crank speed, for the {len(shown)} orders with the largest "
                    "force (log scale).", "mount-forces")
        page.add(peaks_html(ds, shown))
    page.add(f'<p class="note">{_e(_round_off_note(ds, zero, unexcited))}</p>')


def peaks_html(ds, shown: list[int]) -> str:
    """Per mount and for the total, each shown order's largest force over the speeds and the speed of it."""
    rpm = rpm_values(ds)
    amplitude = _speed_first(ds["transmitted_force_amplitude"], ("order", "mount"))
    total = total_force_amplitude(ds)
    largest = float(amplitude.max(initial=0.0))
    k = ds["order"].values
    header = ["mount"] + [h for i in shown for h in (f"order {k[i]:g}: peak [N]", "at [rpm]")]

    def cells(values: np.ndarray) -> list[str]:
        out = []
        for i in shown:
            peak = float(values[:, i].max())
            out += ["0", "—"] if peak <= ZERO_SHARE * largest else [f"{peak:.5g}", f"{rpm[values[:, i].argmax()]:.6g}"]
        return out

    rows = [[str(m)] + cells(amplitude[:, :, j]) for j, m in enumerate(ds["mount"].values)]
    rows.append(["total into the frame"] + cells(total))
    return _table(header, rows) + ('<p class="note">Peak amplitude of each order over the speeds and the crank '
                                   "speed where it occurs; every speed is in the Dataset /mounts.</p>")


def _round_off_note(ds, zero: np.ndarray, unexcited: np.ndarray) -> str:
    """Which orders are left out and why."""
    k = ds["order"].values
    text = ("Round-off is not drawn: orders the engine does not excite (their shaking force, moment and roll are "
            "zero to round-off in the order spectrum: the cylinders' phasors cancel) are left out, and so are "
            f"orders whose transmitted force stays at most {ZERO_SHARE:g} of the largest (shown as 0, as in "
            "harmbal mounts); a value of a drawn order at that share or below is drawn blank and printed 0.")
    for which, why in ((unexcited, "not excited (zero to round-off)"),
                       (zero & ~unexcited, f"at most {ZERO_SHARE:g} of the largest force")):
        if which.any():
            text += f" {'Order' if which.sum() == 1 else 'Orders'} {order_ranges(k[which])}: {why}."
    return text


# -- figures -------------------------------------------------------------------------------------

def _plain_log(axis) -> None:
    """Label a log axis with plain numbers (1000, 0.01): the report draws text literally, with no mathtext."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.set_minor_formatter(NullFormatter())


def _label_heights(values: np.ndarray, gap: float) -> np.ndarray:
    """Heights for labels at ``values`` at least ``gap`` apart (pushed up in order, then centred back)."""
    order = np.argsort(values, kind="stable")
    placed = np.array(values, dtype=float)
    for a, b in zip(order[:-1], order[1:]):
        placed[b] = max(placed[b], placed[a] + gap)
    shift = (placed - values).mean() if values.size else 0.0
    return placed - shift / 2


def modes_figure(mounts: xr.Dataset, *, zero: np.ndarray | None = None,
                 band: tuple[float, float] | None = None) -> Figure:
    """The modes against the orders over the speed range.

    Parameters
    ----------
    mounts : xarray.Dataset
        ``/mounts`` of :func:`harmbal.analyse`.
    zero : array of bool, optional
        Orders not drawn (:func:`zero_orders`); default none.
    band : (float, float), optional
        A frequency band [Hz] to shade (:func:`design_band`).

    Returns
    -------
    matplotlib.figure.Figure
        Each mode's natural frequency as a horizontal line, each excited
        order's frequency k·rpm/60 as a line through the origin (the firing
        order bold), circles at ``crossing_rpm``, the idle firing frequency
        marked at the idle speed.
    """
    from matplotlib.figure import Figure

    freq = mounts["natural_frequency"].values
    firing = float(mounts.attrs["idle_firing_frequency"])
    idle = float(mounts.attrs["idle_speed"]) * 30 / math.pi
    rpm = rpm_values(mounts)
    lo, hi = min(rpm.min(), idle), max(rpm.max(), idle)
    if hi - lo < 1e-6 * hi:  # one speed: the lines over ±25 %
        lo, hi = 0.75 * lo, 1.25 * hi
    top = 1.3 * max(float(freq.max()), firing)
    fig = Figure(figsize=(7.0, 4.4), layout="constrained")
    ax = fig.add_subplot()
    if band is not None:
        ax.axhspan(band[0], min(band[1], top), color=OKABE_ITO["bluish_green"], alpha=0.12, lw=0,
                   label=f"[mount_design] band {band[0]:.3g}–{band[1]:.3g} Hz")
    _order_lines(ax, mounts, zero, (lo, hi), top)
    for f in freq:
        ax.axhline(f, color=OKABE_ITO["blue"], lw=1.4)
    labels = [f"{int(m)} {d} {f:.3g} Hz" for m, d, f in zip(mounts["mode"].values, mounts["dominant_dof"].values, freq)]
    for y, text in zip(_label_heights(freq, 0.045 * top), labels):
        ax.annotate(text, (1.0, y), xycoords=("axes fraction", "data"), xytext=(4, 0), textcoords="offset points",
                    va="center", fontsize=7.5, color=OKABE_ITO["blue"], annotation_clip=False)
    ax.plot([idle], [firing], "o", ms=7, color=OKABE_ITO["vermillion"], zorder=5,
            label=f"idle firing {firing:.3g} Hz at {idle:.4g} rpm")
    ax.axhline(firing, color=OKABE_ITO["vermillion"], lw=0.8, ls=":")
    ax.set_xlim(lo, hi)
    ax.set_ylim(0, top)
    ax.locator_params(nbins=5)
    ax.set_xlabel("crank speed [rpm]")
    ax.set_ylabel("frequency [Hz]")
    ax.legend(loc="lower right", fontsize=7.5, framealpha=0.9)
    ax.set_title(fitted(f"{mounts.attrs.get('engine', '')}: rigid-body modes and the excited orders", 5.5, 10),
                 fontsize=10)
    return fig


def _order_lines(ax: Axes, mounts, zero, span: tuple[float, float], top: float) -> None:
    """Each excited order's line k·rpm/60 within the axes, labelled where it leaves them, and its crossings."""
    lo, hi = span
    firing_order = float(mounts.attrs["firing_order"])
    k_all = mounts["order"].values
    crossing = mounts["crossing_rpm"].transpose("mode", "order").values
    for i, k in enumerate(k_all):
        if (zero is not None and zero[i]) or k * lo / 60 >= top:
            continue
        firing = abs(k - firing_order) < 1e-9
        x = np.array([lo, min(hi, 60 * top / k)])
        colour, width = (OKABE_ITO["vermillion"], 1.8) if firing else ("#777777", 0.8)
        ax.plot(x, k * x / 60, color=colour, lw=width)
        ax.annotate(f"{k:g}×", (x[1], k * x[1] / 60), xytext=(-3, -2), textcoords="offset points", fontsize=7.5,
                    color=colour, ha="right", va="top")
        at = crossing[:, i][np.isfinite(crossing[:, i])]
        if at.size:
            ax.plot(at, k * at / 60, "o", mfc="none", mec=colour, ms=5)


def force_map_figure(mounts: xr.Dataset, *, zero: np.ndarray | None = None) -> Figure:
    """Campbell map of the total force into the frame (order × rpm).

    Parameters
    ----------
    mounts : xarray.Dataset
        ``/mounts`` with several speeds.
    zero : array of bool, optional
        Orders drawn blank (:func:`zero_orders`).

    Returns
    -------
    matplotlib.figure.Figure
        :func:`total_force_amplitude` over (rpm, order) on a logarithmic colour
        scale over :data:`MAP_DECADES` decades; zero orders and values at most
        :data:`ZERO_SHARE` of the largest blank.
    """
    from matplotlib import colormaps
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    rpm, order = rpm_values(mounts), mounts["order"].values
    amplitude = total_force_amplitude(mounts)
    largest = float(amplitude.max(initial=0.0)) or 1.0
    shown = np.where(amplitude <= ZERO_SHARE * largest, np.nan, amplitude)
    if zero is not None:
        shown[:, np.asarray(zero, dtype=bool)] = np.nan
    floor = largest * 10.0 ** -MAP_DECADES
    fig = Figure(figsize=(7.0, 4.4), layout="constrained")
    ax = fig.add_subplot()
    # Edges in the face colour: without them a browser's anti-aliasing shows seams between the cells.
    mesh = ax.pcolormesh(rpm, order, np.ma.masked_invalid(np.maximum(shown, floor)).T, shading="nearest",
                         cmap=colormaps["viridis"].with_extremes(bad="white"), norm=LogNorm(vmin=floor, vmax=largest),
                         edgecolors="face", linewidth=0.3)
    bar = fig.colorbar(mesh, ax=ax, label="total force amplitude [N]")
    _plain_log(bar.ax.yaxis)
    ax.set_xlabel("crank speed [rpm]")
    ax.set_ylabel("order")
    ax.locator_params(axis="x", nbins=5)
    ax.set_title(fitted(f"{mounts.attrs.get('engine', '')}: force into the frame per order and speed", 5.5, 10),
                 fontsize=10)
    return fig


def mount_force_figure(mounts: xr.Dataset, *, orders: tuple[int, ...]) -> Figure:
    """Each mount's transmitted force amplitude against crank speed.

    Parameters
    ----------
    mounts : xarray.Dataset
        ``/mounts`` of :func:`harmbal.analyse`.
    orders : tuple of int
        Indices along ``order`` of the orders drawn (:func:`largest_orders`).

    Returns
    -------
    matplotlib.figure.Figure
        One axes per mount (two columns, shared axes, log scale); values at
        most :data:`ZERO_SHARE` of the largest are not drawn.
    """
    from matplotlib.figure import Figure

    rpm, k = rpm_values(mounts), mounts["order"].values
    amplitude = _speed_first(mounts["transmitted_force_amplitude"], ("order", "mount"))
    amplitude = np.where(amplitude <= ZERO_SHARE * float(amplitude.max(initial=0.0)), np.nan, amplitude)
    names = [str(m) for m in mounts["mount"].values]
    columns = 2 if len(names) > 1 else 1
    rows = math.ceil(len(names) / columns)
    fig = Figure(figsize=(7.0, 1.2 + 2.0 * rows), layout="constrained")
    axes = fig.subplots(rows, columns, sharex=True, sharey=True, squeeze=False).ravel()
    marker = "o" if rpm.size == 1 else None
    for j, (ax, name) in enumerate(zip(axes, names)):
        for n, i in enumerate(orders):
            ax.plot(rpm, amplitude[:, i, j], marker=marker, lw=1.3, label=f"order {k[i]:g}", **series_style(n))
        ax.set_yscale("log")
        _plain_log(ax.yaxis)
        ax.grid(True, which="major", color="#dddddd", lw=0.6)
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=8)
        ax.locator_params(axis="x", nbins=5)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    for ax in axes[len(names) - columns:len(names)]:  # the lowest drawn in each column: ticks and label
        ax.tick_params(labelbottom=True)
        ax.set_xlabel("crank speed [rpm]", fontsize=8)
    for ax in axes[::columns]:
        ax.set_ylabel("|f| [N]", fontsize=8)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(orders), fontsize=8)
    suptitle(fig, f"{mounts.attrs.get('engine', '')}: force each mount transmits, largest orders", 10)
    return fig
