"""The ``.harmbal`` accessor: harmbal's Datasets and analysis trees in a notebook.

Importing this module registers ``.harmbal`` on :class:`xarray.Dataset` and
:class:`xarray.DataTree`. :mod:`harmbal` imports it the first time one of its
functions that return xarray objects is looked up (``hb.analyse``,
``hb.order_spectrum``, ``hb.stars``, ``hb.design``, ``hb.verify``,
``hb.open_archive``, …), so ``import harmbal`` itself stays light; ``import
harmbal.accessor`` registers it for Datasets read without harmbal's functions.

What it gives, in engineering units (N, N m, degrees, rpm):

- tidy :class:`pandas.DataFrame` tables: :meth:`~DatasetAccessor.amplitudes`
  (amplitude |C_k| and phase per order and engine axis),
  :meth:`~DatasetAccessor.rotating` (the co- and counter-rotating phasors) and
  :meth:`~DatasetAccessor.classes` (zero, negligible or free per order and
  component, docs/conventions.md#zero-negligible-free), from an order Dataset
  (``/orders``, :func:`harmbal.order_spectrum`), a stars Dataset
  (:func:`harmbal.stars`) or an analysis tree (its ``/orders``);
- :meth:`~DatasetAccessor.sel_rpm`: one speed by its rpm, exactly;
- :meth:`~DatasetAccessor.summary`: the tables ``harmbal run``, ``stars``,
  ``design`` and ``verify`` print, as text and as HTML in a notebook;
- the standard figures (:mod:`harmbal.reporting.plots`,
  :mod:`harmbal.reporting.sweep_plots`) as methods returning
  :class:`matplotlib.figure.Figure` objects; matplotlib is imported only
  when one is drawn.

>>> import harmbal as hb
>>> tree = hb.analyse(hb.load_scene("datasets/engines/tractor-3cyl.toml"))  # doctest: +SKIP
>>> tree.harmbal.amplitudes("moment").loc[1]                                # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np
import pandas as pd
import xarray as xr

from .balance.summaries import design_html, design_text, escape, html_block, html_list, html_table, phasor_text
from .balance.verify import describe_component
from .orders.spectrum import CLASSES, NEGLIGIBLE, ZERO, classify, phase_degrees
from .reporting.tables import ORDER_VALUES, cell_classes, order_table, stars_table, targeted_rows, verify_table

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Quantities of the order tables and their SI units.
QUANTITIES = {"force": "N", "moment": "N m"}

#: Components of :meth:`DatasetAccessor.classes`: (column, quantity, cell of
#: :func:`harmbal.reporting.tables.cell_classes`: x, y, z, co, counter).
CLASS_COLUMNS = (("force_co", "force", 3), ("force_counter", "force", 4), ("moment_co", "moment", 3),
                 ("moment_counter", "moment", 4), ("roll", "moment", 0))

#: Relative difference [1] within which :meth:`DatasetAccessor.sel_rpm` takes a
#: speed as the one asked for: round-off of the rpm ↔ rad/s conversion, not a
#: nearest-neighbour search.
RPM_RTOL = 1e-12


def dataset_kind(ds: xr.Dataset) -> str:
    """What a harmbal Dataset holds, from its variables.

    Returns
    -------
    str
        ``"orders"`` (:func:`harmbal.order_spectrum`, ``/orders``),
        ``"stars"`` (:func:`harmbal.stars`, ``/stars``), ``"time"``
        (:func:`harmbal.simulate`, ``/time``), ``"verify"``
        (:func:`harmbal.verify`), ``"design"`` (``Design.dataset``),
        ``"loads"`` (:func:`harmbal.loads`, ``/loads``) or ``"other"``.
    """
    if "star_angle" in ds:
        return "stars"
    if "exact" in ds and "tolerance" in ds:
        return "verify"
    if "unbalance" in ds and "predicted" in ds:
        return "design"
    if "crank_pin_force" in ds or "main_bearing_force" in ds:
        return "loads"
    if "force" in ds and "angle" in ds["force"].dims:
        return "time"
    if "force_rotating" in ds and "axis" in ds["force"].dims and not {"variant", "sample"} & set(ds.dims):
        return "orders"
    return "other"


class Summary:
    """A table to read: its text is the ``repr`` (and ``str``), its HTML what
    a notebook shows (``_repr_html_``).

    Attributes
    ----------
    text : str
        Plain text, as the command line prints it.
    html : str
        HTML with every text escaped.
    """

    def __init__(self, text: str, html_text: str):
        self.text = text
        self.html = html_text

    def __repr__(self) -> str:
        return self.text

    __str__ = __repr__

    def _repr_html_(self) -> str:
        return self.html


# Speeds: the rpm coordinate, exact selection.


def _rpm_values(ds: xr.Dataset) -> np.ndarray:
    if "rpm" in ds.coords:
        return np.atleast_1d(np.asarray(ds["rpm"].values, dtype=float))
    if "speed" in ds.coords:
        return np.atleast_1d(np.asarray(ds["speed"].values, dtype=float)) * 30 / np.pi
    raise KeyError("the Dataset has no crank speed (coordinates rpm or speed)")


def _speed_dim(ds: xr.Dataset) -> str | None:
    """The dimension along the speeds (``speed``, or ``rpm`` when that is the
    dimension), None for a Dataset at one speed."""
    name = "rpm" if "rpm" in ds.coords else "speed"
    dims = ds[name].dims if name in ds.coords else ()
    return cast(str, dims[0]) if dims else None  # harmbal names its dimensions with strings


def speed_index(ds: xr.Dataset, rpm: float) -> int:
    """The position of the speed ``rpm`` [rpm] among the Dataset's speeds.

    Raises
    ------
    KeyError
        If ``rpm`` is not one of the speeds (to round-off, :data:`RPM_RTOL`),
        naming the speeds present.
    """
    values = _rpm_values(ds)
    matches = np.flatnonzero(np.isclose(values, float(rpm), rtol=RPM_RTOL, atol=0))
    if not matches.size:
        present = ", ".join(f"{v:.10g}" for v in values)
        raise KeyError(f"{float(rpm):.10g} rpm is not a speed of this Dataset; its speeds are {present} rpm")
    return int(matches[0])


def sel_rpm(ds: xr.Dataset, rpm: float) -> xr.Dataset:
    """The Dataset at the speed ``rpm`` [rpm], without its speed dimension
    (the Dataset itself if it has one speed and that is it)."""
    index = speed_index(ds, rpm)
    dim = _speed_dim(ds)
    return ds if dim is None else ds.isel({dim: index})


def _at_speeds(ds: xr.Dataset, rpm: float | None) -> list[tuple[float, xr.Dataset]]:
    """(rpm, Dataset at that speed) of every speed, or of ``rpm`` alone."""
    values, dim = _rpm_values(ds), _speed_dim(ds)
    indices = range(values.size) if rpm is None else [speed_index(ds, rpm)]
    return [(float(values[i]), ds if dim is None else ds.isel({dim: i})) for i in indices]


# Tables.


def _phases(phasors: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """Phases [deg] in (−180, 180] of ``phasors``; NaN where the class is
    zero (round-off: the phase means nothing)."""
    return np.where(codes == ZERO, np.nan, phase_degrees(phasors))


def _class_names(codes: np.ndarray) -> pd.Categorical:
    """Class codes as an ordered categorical of :data:`~harmbal.orders.spectrum.CLASSES`."""
    return pd.Categorical.from_codes(np.asarray(codes, dtype=int).ravel(), categories=list(CLASSES), ordered=True)


def _codes(sel: xr.Dataset) -> dict:
    """:func:`harmbal.reporting.tables.cell_classes` of a Dataset at one speed:
    per quantity the class codes (order, x/y/z/co/counter) and the levels."""
    return cell_classes({name: sel[name].values for name in ORDER_VALUES if name in sel}, sel.attrs)


def _phasor_frame(phasors: np.ndarray, codes: np.ndarray, orders, labels, level: str) -> pd.DataFrame:
    """Rows per (order, ``level``): amplitude |C|, phase [deg], class."""
    index = pd.MultiIndex.from_product([np.asarray(orders), [str(v) for v in labels]], names=["order", level])
    return pd.DataFrame({"amplitude": np.abs(phasors).ravel(), "phase": _phases(phasors, codes).ravel(),
                         "class": _class_names(codes)}, index=index)


def _by_speed(frames: list[tuple[float, pd.DataFrame]], ds: xr.Dataset, rpm: float | None) -> pd.DataFrame:
    """One frame of the ``frames`` per speed, with an ``rpm`` index level in
    front when ``ds`` has several speeds and no one speed ``rpm`` was asked for."""
    if rpm is not None or _speed_dim(ds) is None:
        return frames[0][1]
    return pd.concat([frame for _, frame in frames], keys=[r for r, _ in frames], names=["rpm"])


def _labelled(frame: pd.DataFrame, ds: xr.Dataset, what: str, units: dict) -> pd.DataFrame:
    frame.attrs.update({"engine": ds.attrs.get("engine", ""), "what": what, "units": units})
    return frame


def _phasor_table(ds: xr.Dataset, quantity: str, rpm: float | None, cells: tuple, what: str) -> pd.DataFrame:
    """A table of phasors per order and label: ``cells`` = (variable, its
    columns among :func:`_codes`' x, y, z, co, counter, the label's dim)."""
    unit = _unit(ds, quantity)
    variable, columns, dim = cells
    frames = [(r, _phasor_frame(sel[variable].transpose("order", dim).values, _codes(sel)[quantity][:, columns],
                                sel["order"].values, sel[dim].values, dim))
              for r, sel in _at_speeds(ds, rpm)]
    return _labelled(_by_speed(frames, ds, rpm), ds, what, {"amplitude": unit, "phase": "deg"})


class DatasetAccessor:
    """``ds.harmbal``: tables, exact speed selection, summaries and figures of
    a harmbal Dataset (see :mod:`harmbal.accessor`)."""

    def __init__(self, ds: xr.Dataset):
        self._ds = ds

    @property
    def kind(self) -> str:
        """What the Dataset holds (:func:`dataset_kind`)."""
        return dataset_kind(self._ds)

    def _require(self, kinds: tuple[str, ...], what: str) -> xr.Dataset:
        if self.kind not in kinds:
            raise ValueError(f"{what} needs a harmbal {' or '.join(kinds)} Dataset; this one is {self.kind!r}")
        return self._ds

    def _phasors(self, what: str, kinds: tuple[str, ...] = ("orders", "stars")) -> xr.Dataset:
        """The Dataset of the order tables: an order Dataset, or a stars Dataset with its free vectors."""
        ds = self._require(kinds, what)
        if "force" not in ds:
            raise ValueError(f"{what}: this /stars holds no free vectors (an analysis tree keeps them in /orders): "
                             "use the tree's .harmbal, or harmbal.views.stars.with_free_vectors(stars, orders)")
        if not np.issubdtype(ds["force"].dtype, np.complexfloating):
            raise ValueError(f"{what}: the phasors are stored as real and imaginary parts (an archive read with plain "
                             "xarray): read it with hb.open_archive")
        return ds

    def sel_rpm(self, rpm: float) -> xr.Dataset:
        """The Dataset at one crank speed, chosen by its rpm.

        Parameters
        ----------
        rpm : float
            Crank speed [rpm]; must be one of the Dataset's speeds (to the
            round-off of the rpm ↔ rad/s conversion): no nearest speed.

        Returns
        -------
        xarray.Dataset
            Without the speed dimension; ``speed`` [rad/s] and ``rpm`` stay
            as scalar coordinates.

        Raises
        ------
        KeyError
            If ``rpm`` is not a speed of the Dataset; the message names the
            speeds present.
        """
        return sel_rpm(self._ds, rpm)

    def amplitudes(self, quantity: str = "moment", rpm: float | None = None) -> pd.DataFrame:
        """Amplitude and phase of every order per engine axis.

        Parameters
        ----------
        quantity : {"moment", "force"}
            The shaking moment about the reference point [N m] or force [N].
        rpm : float, optional
            One crank speed [rpm] (:meth:`sel_rpm`); default every speed.

        Returns
        -------
        pandas.DataFrame
            Index (``order``, ``axis``), with ``rpm`` in front for a Dataset
            of several speeds and no ``rpm`` given. Columns ``amplitude``:
            the peak |C_k| [N or N m]; ``phase``: arg C_k [deg] in
            (−180, 180] at θ = 0 (throw 1 along +z), NaN where the component
            is zero (round-off); ``class``: ``zero``, ``negligible`` or
            ``free`` (the axis x of the moment is the roll's class; y and z
            are judged against the same negligible level as co/counter).
            ``frame.attrs["units"]`` holds the units.
        """
        return _phasor_table(self._phasors("amplitudes()"), quantity, rpm, (quantity, slice(0, 3), "axis"),
                             f"{quantity} per order and axis")

    def rotating(self, quantity: str = "moment", rpm: float | None = None) -> pd.DataFrame:
        """The co- and counter-rotating phasors of the transverse vector per order.

        Parameters
        ----------
        quantity : {"moment", "force"}
            The transverse (y, z) moment [N m] or force [N].
        rpm : float, optional
            One crank speed [rpm] (:meth:`sel_rpm`); default every speed.

        Returns
        -------
        pandas.DataFrame
            Index (``order``, ``rotation`` = co, counter), with ``rpm`` in
            front for several speeds; columns ``amplitude`` |P| [N or N m],
            ``phase`` arg P [deg] in (−180, 180] (the direction of the
            rotating vector at θ = 0, from +z in the direction of rotation;
            NaN where zero) and ``class``, as stored in ``force_rotating``,
            ``moment_rotating`` and their ``*_class``
            (docs/conventions.md#co--and-counter-rotating-phasors).
        """
        return _phasor_table(self._phasors("rotating()"), quantity, rpm,
                             (f"{quantity}_rotating", slice(3, 5), "rotation"),
                             f"co- and counter-rotating {quantity} per order")

    def classes(self, rpm: float | None = None) -> pd.DataFrame:
        """The verdict per order: zero, negligible or free.

        Parameters
        ----------
        rpm : float, optional
            One crank speed [rpm]; default every speed (the force and
            transverse moment classes hold at every speed; with gas, the
            roll's may not).

        Returns
        -------
        pandas.DataFrame
            Index ``order`` (with ``rpm`` in front for several speeds),
            columns ``force_co``, ``force_counter``, ``moment_co``,
            ``moment_counter``, ``roll``: ordered categoricals of ``zero`` <
            ``negligible`` < ``free``, the Dataset's ``force_class``,
            ``moment_class`` and ``roll_class``. ``frame.attrs["levels"]``:
            the negligible levels [N, N m] at the first speed shown.
        """
        ds = self._phasors("classes()")
        speeds = _at_speeds(ds, rpm)
        frames = []
        for r, sel in speeds:
            codes = _codes(sel)
            index = pd.Index(sel["order"].values, name="order")
            frames.append((r, pd.DataFrame({column: _class_names(codes[quantity][:, cell])
                                            for column, quantity, cell in CLASS_COLUMNS}, index=index)))
        frame = _by_speed(frames, ds, rpm)
        frame.attrs["levels"] = _codes(speeds[0][1])["levels"]
        return _labelled(frame, ds, "class per order and component", {})

    def summary(self) -> Summary:
        """The table the command line prints for this Dataset, as text and HTML.

        Returns
        -------
        Summary
            Of a verify Dataset (:func:`harmbal.verify`): per targeted order
            and component the value before, the predicted and the exact
            residual, pass or fail, the peaks removed per axis and the
            components made worse; of a design Dataset: the elements and
            the targets; of an order or stars Dataset: ``harmbal run``'s or
            ``harmbal stars``' table.

        Raises
        ------
        ValueError
            For other Datasets.
        """
        kind = self.kind
        if kind == "verify":
            return Summary(verify_table(self._ds), _verify_html(self._ds))
        if kind == "design":
            return _design_summary(self._ds)
        if kind == "orders":
            return _text_summary(self._ds.attrs.get("title", "order spectrum"), order_table(self._ds))
        if kind == "stars" and "force" in self._ds:
            return _text_summary(self._ds.attrs.get("title", "crank stars"), stars_table(self._ds))
        raise ValueError(f"summary() reads a verify, design, orders or stars Dataset (with free vectors); this one is "
                         f"{kind!r}")

    # Figures.

    def plot_spectrum(self, *, log: bool = False, max_order: int | None = None, rpm: float | None = None) -> Figure:
        """The order spectrum (:func:`harmbal.reporting.plots.order_spectrum_figure`).

        Parameters
        ----------
        log : bool, default False
            Logarithmic amplitude axis.
        max_order : int, optional
            Highest order drawn; default all.
        rpm : float, optional
            Crank speed [rpm]; default the first.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .reporting.plots import order_spectrum_figure

        ds = self._require(("orders",), "plot_spectrum()")
        return order_spectrum_figure(ds, log=log, max_order=max_order, speed=self._index(rpm))

    def plot_stars(self, orders=None, *, rpm: float | None = None) -> Figure:
        """Crank stars and the free force and moment phasor diagrams
        (:func:`harmbal.reporting.plots.stars_figure`).

        Parameters
        ----------
        orders : sequence of int, optional
            Orders to draw (one row each); default 1, 2 and the free orders.
        rpm : float, optional
            Crank speed [rpm]; default the first.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .reporting.plots import stars_figure

        ds = self._phasors("plot_stars()", ("stars",))
        return stars_figure(ds, orders, speed=None if rpm is None else _rpm_values(ds)[speed_index(ds, rpm)])

    def plot_campbell(self, quantity: str = "force") -> Figure:
        """Order against crank speed of a speed sweep
        (:func:`harmbal.reporting.sweep_plots.campbell_figure`).

        Parameters
        ----------
        quantity : {"force", "moment"}

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .reporting.sweep_plots import campbell_figure

        return campbell_figure(self._require(("orders",), "plot_campbell()"), name=quantity)

    def plot_traces(self, *, rpm: float | None = None) -> Figure:
        """Force and moment over the revolution
        (:func:`harmbal.reporting.plots.time_traces_figure`) of a time
        Dataset, at its own samples (``hb.simulate(scene, samples_per_rev=720)``
        for smooth curves).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .reporting.plots import time_traces_figure

        return time_traces_figure(self._require(("time",), "plot_traces()"), speed=self._index(rpm))

    def plot_locus(self, *, rpm: float | None = None) -> Figure:
        """The loci of the transverse force and moment over the revolution
        (:func:`harmbal.reporting.plots.locus_figure`) of a time Dataset.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .reporting.plots import locus_figure

        return locus_figure(self._require(("time",), "plot_locus()"), speed=self._index(rpm))

    def plot_polar(self, which: str = "crank_pin", *, cylinders=None, rpm: float | None = None) -> Figure:
        """Polar diagrams of a loads Dataset (:func:`harmbal.loads`, ``/loads``).

        Parameters
        ----------
        which : {"crank_pin", "main_bearing"}
            The crank pin and big end per cylinder
            (:func:`harmbal.reporting.plots.crank_pin_figure`) or the main
            bearings (:func:`~harmbal.reporting.plots.main_bearing_figure`,
            when the scene's ``[loads]`` table has them).
        cylinders : sequence of str, optional
            Cylinder labels of the crank-pin diagrams; default all.
        rpm : float, optional
            Crank speed [rpm]; default the first.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .reporting.plots import crank_pin_figure, main_bearing_figure

        ds = self._require(("loads",), "plot_polar()")
        if which == "crank_pin":
            return crank_pin_figure(ds, cylinders=cylinders, speed=self._index(rpm))
        if which == "main_bearing":
            if "main_bearing_force" not in ds:
                raise ValueError("plot_polar('main_bearing'): no main bearings (the scene's [loads] table names them)")
            return main_bearing_figure(ds, speed=self._index(rpm))
        raise ValueError(f"which must be 'crank_pin' or 'main_bearing', not {which!r}")

    def _index(self, rpm: float | None) -> int:
        """The speed index the plotting functions take, of ``rpm`` (default the first)."""
        return 0 if rpm is None else speed_index(self._ds, rpm)


def _unit(ds: xr.Dataset, quantity: str) -> str:
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be 'force' or 'moment', not {quantity!r}")
    return str(ds[quantity].attrs.get("units", QUANTITIES[quantity]))


def _text_summary(title: str, text: str) -> Summary:
    return Summary(text, html_block(title, [f"<pre>{escape(text)}</pre>"]))


def _design_summary(ds: xr.Dataset) -> Summary:
    """A design Dataset's summary (as ``repr(Design)``), its messages read from the attributes."""
    lines = [(ds.attrs.get(name) or "").splitlines() for name in ("messages", "worsened")]
    name = ds.attrs.get("engine", "")
    return Summary(design_text(ds, name, *lines), design_html(ds, name, *lines))


def _verify_row(k: int, name: str, row, units: str) -> list[str]:
    """A targeted row of a verify Dataset: before, predicted, exact residual (0 where round-off), |Δ|, result."""
    exact = 0j if "exact_class" in row and int(row["exact_class"]) == ZERO else complex(row["exact"])
    return [describe_component(k, name), phasor_text(complex(row["before"]), units),
            phasor_text(complex(row["predicted"]), units), phasor_text(exact, units),
            f"{float(row['difference']):.2g}", f"{float(row['tolerance']):.2g}",
            "pass" if bool(row["passed"]) else "FAIL"]


def _classed(value: float, scale: float, level: float, units: str) -> str:
    """An amplitude [N or N m] by its class: ``0`` (round-off), ``~0`` (negligible) or its value."""
    code = int(classify(value, scale, level))
    return {ZERO: f"0 {units}", NEGLIGIBLE: f"~0 {units}"}.get(code, f"{value:.5g} {units}")


def _peak_rows(sel: xr.Dataset) -> list[list[str]]:
    """Per quantity and axis: the peak over the revolution before and after [N or N m], the share removed [%]."""
    rows = []
    for quantity, units in QUANTITIES.items():
        scale = float(sel[f"{quantity}_scale"])
        level = float(sel[f"{quantity}_negligible_level"]) if f"{quantity}_negligible_level" in sel else 0.0
        for axis in sel["axis"].values:
            was, now, removed = (float(sel[f"peak_{quantity}_{when}"].sel(axis=axis))
                                 for when in ("before", "after", "removed"))
            rows.append([f"{quantity} {axis}", _classed(was, scale, level, units), _classed(now, scale, level, units),
                         f"{round(removed, 1) + 0.0:.1f} %"])
    return rows


def _verify_html(check: xr.Dataset) -> str:
    """A verify Dataset as HTML: per speed the targeted rows and the peaks per axis, then what is made worse."""
    state = "PASSED" if check.attrs.get("passed") == "yes" else "FAILED"
    parts = [f"<p>Tolerance: {escape(check.attrs.get('tolerance_rule', ''))}.</p>"]
    for rpm, sel in _at_speeds(check, None):
        parts += [f"<p>At {rpm:.6g} rpm:</p>",
                  html_table(["order and component", "before", "predicted", "exact residual", "|Δ|", "tolerance",
                              "result"], [_verify_row(*row) for row in targeted_rows(sel)]),
                  html_table(["peak over the revolution", "before", "after", "removed"], _peak_rows(sel))]
    worsened = (check.attrs.get("worsened") or "").splitlines()
    parts.append(html_list(worsened) if worsened else "<p>Nothing else made worse by the balancer elements.</p>")
    return html_block(f"Verification of the balancers of {check.attrs.get('engine', '')} by the exact model "
                      f"({check.attrs.get('samples_per_rev', '?')} samples/rev): {state}", parts)


class TreeAccessor:
    """``tree.harmbal``: the accessor of an analysis tree
    (:func:`harmbal.analyse`, :func:`harmbal.open_archive`); each method
    reads the group it needs (``/orders`` for the tables and the spectrum)."""

    def __init__(self, tree: xr.DataTree):
        self._tree = tree

    def _group(self, name: str, what: str) -> xr.Dataset:
        if name not in self._tree.children:
            raise KeyError(f"{what} reads /{name}, which this tree does not have (groups "
                           f"{', '.join(self._tree.groups)})")
        return self._tree[name].to_dataset()

    def sel_rpm(self, rpm: float) -> xr.DataTree:
        """The tree at one crank speed [rpm], exactly (:meth:`DatasetAccessor.sel_rpm`).

        Raises
        ------
        KeyError
            If ``rpm`` is not one of the tree's speeds; the message names them.
        """
        timed = [node.to_dataset() for node in self._tree.subtree if "rpm" in node.coords or "speed" in node.coords]
        if not timed:
            raise KeyError(f"no group of this tree has crank speeds (groups {', '.join(self._tree.groups)})")
        index, dim = speed_index(timed[0], rpm), _speed_dim(timed[0])
        return self._tree if dim is None else self._tree.isel({dim: index})

    def amplitudes(self, quantity: str = "moment", rpm: float | None = None) -> pd.DataFrame:
        """:meth:`DatasetAccessor.amplitudes` of ``/orders``."""
        return self._group("orders", "amplitudes()").harmbal.amplitudes(quantity, rpm)

    def rotating(self, quantity: str = "moment", rpm: float | None = None) -> pd.DataFrame:
        """:meth:`DatasetAccessor.rotating` of ``/orders``."""
        return self._group("orders", "rotating()").harmbal.rotating(quantity, rpm)

    def classes(self, rpm: float | None = None) -> pd.DataFrame:
        """:meth:`DatasetAccessor.classes` of ``/orders``."""
        return self._group("orders", "classes()").harmbal.classes(rpm)

    def summary(self) -> Summary:
        """``harmbal show``'s tables: ``/orders`` and, when the tree has it, ``/verify``."""
        parts = [self._group("orders", "summary()").harmbal.summary()]
        if "verify" in self._tree.children:
            parts.append(self._tree["verify"].to_dataset().harmbal.summary())
        return Summary("\n\n".join(p.text for p in parts), "".join(p.html for p in parts))

    def plot_spectrum(self, *, log: bool = False, max_order: int | None = None, rpm: float | None = None) -> Figure:
        """:meth:`DatasetAccessor.plot_spectrum` of ``/orders``."""
        return self._group("orders", "plot_spectrum()").harmbal.plot_spectrum(log=log, max_order=max_order, rpm=rpm)

    def plot_stars(self, orders=None, *, rpm: float | None = None) -> Figure:
        """:meth:`DatasetAccessor.plot_stars` of ``/stars`` with the free
        vectors of ``/orders`` (:func:`harmbal.views.stars.with_free_vectors`)."""
        from .views.stars import with_free_vectors

        stars = with_free_vectors(self._group("stars", "plot_stars()"), self._group("orders", "plot_stars()"))
        return stars.harmbal.plot_stars(orders, rpm=rpm)

    def plot_campbell(self, quantity: str = "force") -> Figure:
        """:meth:`DatasetAccessor.plot_campbell` of ``/orders``."""
        return self._group("orders", "plot_campbell()").harmbal.plot_campbell(quantity)

    def plot_traces(self, *, rpm: float | None = None) -> Figure:
        """:meth:`DatasetAccessor.plot_traces` of ``/time`` (its samples per revolution)."""
        return self._group("time", "plot_traces()").harmbal.plot_traces(rpm=rpm)

    def plot_locus(self, *, rpm: float | None = None) -> Figure:
        """:meth:`DatasetAccessor.plot_locus` of ``/time``."""
        return self._group("time", "plot_locus()").harmbal.plot_locus(rpm=rpm)

    def plot_polar(self, which: str = "crank_pin", *, cylinders=None, rpm: float | None = None) -> Figure:
        """:meth:`DatasetAccessor.plot_polar` of ``/loads`` (a scene with a ``[loads]`` table)."""
        return self._group("loads", "plot_polar()").harmbal.plot_polar(which, cylinders=cylinders, rpm=rpm)


xr.register_dataset_accessor("harmbal")(DatasetAccessor)
xr.register_datatree_accessor("harmbal")(TreeAccessor)
