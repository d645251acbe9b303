"""Plain-text summary of a design sweep or a Monte Carlo run, for the CLI."""

from __future__ import annotations

import numpy as np

#: Percentiles [%] the summary prints.
PERCENTILES = (0, 5, 50, 95, 100)


def _dim(ds) -> str:
    return "sample" if "sample" in ds.dims else "variant"


def _at_top_speed(ds):
    """The Dataset at its highest speed (where inertial residuals are largest) and that speed in rpm."""
    if "speed" in ds.dims:
        i = int(np.argmax(ds["speed"].values))
        return ds.isel(speed=i), float(ds["rpm"].values[i])
    return ds, float(np.atleast_1d(ds.attrs["speed_rad_s"])[0]) * 30 / np.pi


def _key_value(ds, key: str, i: int) -> str:
    units = ds[key].attrs.get("units", "")
    return f"{key} = {float(ds[key].values[i]):.6g}" + (f" {units}" if units else "")


def table_inputs(ds):
    """What :func:`sweep_table` reads from ``ds``: everything but the phasors
    (the variables along ``axis`` or ``rotation``, with or without the design),
    so that a chunked sweep computes this much into memory, not the phasors."""
    return ds.drop_vars([n for n, v in ds.data_vars.items() if {"axis", "rotation"} & set(v.dims)])


def _all_cancelled(ds) -> np.ndarray:
    """(variant,) whether the design cancelled every component it targeted."""
    cancelled = ds["design_cancelled"].transpose(_dim(ds), "design_order", "component").values
    return cancelled[:, ds["design_targeted"].transpose("design_order", "component").values].all(axis=1)


def sweep_table(ds) -> str:
    """Best and worst variant and percentiles of the order residuals.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`harmbal.sweep` or :func:`harmbal.monte_carlo`.

    Returns
    -------
    str
        The residual of a variant is its order amplitudes (peak of each
        order's force or moment vector over a revolution) summed over the
        orders of ``ds``; the best and worst variants by force and by moment
        with their key values and amplitudes per order, then percentiles per
        order (and mean, standard deviation and exceedance shares of a Monte
        Carlo run).
    """
    dim = _dim(ds)
    ds, rpm = _at_top_speed(table_inputs(ds).compute())  # one pass over a chunked sweep
    orders = [int(k) for k in ds["order"].values]
    count = ds.sizes[dim]
    # An archive gives lists of one item back as scalars.
    keys = [str(k) for k in np.atleast_1d(ds.attrs.get("parameters", []))]
    shape = ds.attrs.get("grid_shape")
    if dim == "sample":
        how = f"seed {ds.attrs.get('seed', 'none')}"
    else:
        how = f"grid {' × '.join(map(str, np.atleast_1d(shape)))}" if shape is not None else ds.attrs.get("mode", "")
    geometries = int(ds.attrs.get("geometries", 0))
    lines = [(f"harmbal {'Monte Carlo' if dim == 'sample' else 'sweep'}: {ds.attrs.get('engine', '')}: "
              f"{count} {dim}s ({how}), {geometries} geometr{'y' if geometries == 1 else 'ies'} evaluated, "
              f"at {rpm:.6g} rpm"),
             "keys: " + ", ".join(f"{k} [{ds[k].attrs.get('units', 'SI')}] ({ds[k].attrs.get('kind', '')})"
                                  for k in keys),
             "residual: peak over a revolution of each order's vector; best/worst by its sum over orders "
             + ", ".join(map(str, orders)), ""]
    for name, units in (("force", "N"), ("moment", "N m")):
        amplitude = ds[f"{name}_amplitude"].transpose(dim, "order").values
        total = amplitude.sum(axis=1)
        for label, i in (("best", int(np.argmin(total))), ("worst", int(np.argmax(total)))):
            per_order = ", ".join(f"order {k} {a:.5g}" for k, a in zip(orders, amplitude[i]))
            lines.append(f"{label} by {name}: {dim} {i}: {'; '.join(_key_value(ds, k, i) for k in keys)}")
            lines.append(f"    {name} [{units}]: {per_order}")
    lines.append("")
    rows = [(name, units, label) for name, units, label in (
        ("force", "N", "force"), ("moment", "N m", "moment"), ("residual_force", "N", "force after design"),
        ("residual_moment", "N m", "moment after design")) if f"{name}_amplitude" in ds]
    width = max(len(label) for _, _, label in rows)
    header = f"{'order':>5}  {'':<{width}}" + "".join(f"{f'{q:g} %':>12}" for q in PERCENTILES)
    extra = dim == "sample"
    if extra:
        header += f"{'mean':>12}{'std':>12}"
    lines.append(header)
    for name, units, label in rows:
        amplitude = ds[f"{name}_amplitude"].transpose(dim, "order").values
        stats = np.percentile(amplitude, PERCENTILES, axis=0)
        for j, k in enumerate(orders):
            row = f"{k:>5}  {label:<{width}}" + "".join(f"{v:>12.5g}" for v in stats[:, j])
            if extra:
                row += f"{amplitude[:, j].mean():>12.5g}{amplitude[:, j].std(ddof=1) if count > 1 else 0.0:>12.5g}"
            lines.append(row + f"  {units}")
    if "design_unbalance" in ds:
        unbalance = ds["design_unbalance"].transpose(dim, "element").values
        stats = np.percentile(unbalance, PERCENTILES, axis=0)
        lines.append("")
        lines.append(f"designed per variant ([design], orders {', '.join(map(str, ds['design_order'].values))}): "
                     f"unbalance of each element [kg m], percentiles {', '.join(map(str, PERCENTILES))} %; "
                     f"variants with every target cancelled: "
                     f"{int(_all_cancelled(ds).sum())} of {count}")
        for j, element in enumerate(ds["element"].values):
            lines.append(f"  {element}: " + ", ".join(f"{v:.5g}" for v in stats[:, j]))
    for name, units in (("force", "N"), ("moment", "N m")):
        if f"p_exceed_{name}" in ds:
            share = ds[f"p_exceed_{name}"]
            lines.append(f"share of samples with an order {name} amplitude above {share.attrs['limit']:g} {units}: "
                         + ", ".join(f"order {k} {float(share.sel(order=k)):.4g}" for k in orders))
    if "force_sensitivity" in ds:
        lines.append("")
        lines.append("which tolerance drives the residual (share of the variance of the order amplitude, linear fit):")
        for name in ("force", "moment"):
            share = ds[f"{name}_sensitivity"]
            for k in orders:
                ranked = sorted(zip(share.sel(order=k).values, [str(p) for p in share["parameter"].values]),
                                reverse=True)
                r2 = float(ds[f"{name}_sensitivity_r2"].sel(order=k))
                lines.append(f"  order {k} {name}: " + ", ".join(f"{p} {v:.3g}" for v, p in ranked)
                             + f" (R² {r2:.3g})")
    if "peak_force" in ds:
        lines.append("")
        for name, units in (("force", "N"), ("moment", "N m")):
            q = np.percentile(ds[f"peak_{name}"].values, PERCENTILES)
            lines.append(f"peak {name} over a revolution [{units}], percentiles {', '.join(map(str, PERCENTILES))} %: "
                         + ", ".join(f"{v:.5g}" for v in q))
    return "\n".join(lines)
