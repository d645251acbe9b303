"""Balancer design of many mass variants of one geometry (harmbal.balance.variants)
against hb.design of each variant.

Oracle: each variant is written into the scene mapping by hand, loaded, designed by
hb.design (which evaluates the model of that variant and solves its own least squares)
and its designed scene re-analysed by order_phasors; design_variants applies affine maps
built once from another variant. They agree to 1e-12 of the variant's scale (design's
force_scale for unbalances and forces, as a force per ω² is kg m; moment_scale for
moments): the maths is exact, so what is left is round-off.
"""

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.balance.solvers import DesignError
from harmbal.balance.variants import (
    _scale_bounds,
    _scales,
    design_basis,
    design_variants,
)
from harmbal.model.evaluate import evaluate
from harmbal.orders.linear import linear_phasors, slot_values
from harmbal.orders.phasors import order_phasors

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"
RTOL = 1e-12


def _raw(name):
    return tomllib.loads((ENGINES / f"{name}.toml").read_text(encoding="utf-8"))


def _with_throw_unbalance(raw):
    raw["throw_unbalance"] = [{"unbalance": "0.02 kg m", "angle": "30 deg"}]
    return raw


def _variant(raw, rng):
    """The scene with each cylinder's masses (and throw unbalances) and the
    crankshaft unbalances scaled by random factors in [0.6, 1.6]."""
    raw = copy.deepcopy(raw)
    scene = hb.load_scene(copy.deepcopy(raw))
    for entry, c in zip(raw["cylinder"], scene.cylinders):
        entry["piston"] = {"mass": c.piston.mass * rng.uniform(0.6, 1.6)}
        entry["rod"] = {"mass": c.rod.mass * rng.uniform(0.6, 1.6)}
        if c.rod.inertia is not None:
            entry["rod"]["inertia"] = c.rod.inertia * rng.uniform(0.6, 1.6)
        if c.throw_unbalances:
            entry["throw_unbalance"] = [{"unbalance": u.unbalance * rng.uniform(0.6, 1.6), "angle": u.angle}
                                        for u in c.throw_unbalances]
    for entry in raw.get("crankshaft_unbalance", []):
        entry["mass"] = f"{float(entry['mass'].split()[0]) * rng.uniform(0.6, 1.6)!r} kg"
    return raw


def _designs(raw, count, seed):
    """design_variants of ``count`` random variants (the map built from the
    scene itself), the scenes, and the variants' scales with their bounds."""
    rng = np.random.default_rng(seed)
    scene = hb.load_scene(copy.deepcopy(raw))
    basis = linear_phasors(scene)
    variants = [hb.load_scene(_variant(raw, rng)) for _ in range(count)]
    slots = []
    for v in variants:
        names, values = slot_values(v)
        assert names == basis.slots
        slots.append(values)
    dbasis = design_basis(scene, basis)
    scales = _scales(dbasis.bounds, np.array(slots)) + _scale_bounds(dbasis.bounds, np.array(slots))
    return design_variants(dbasis, np.array(slots)), variants, scales


def _mass_variants(raw, scene, count, inertia=False):
    """``count`` scenes of ``raw`` with the shared piston and rod masses (and rod inertia) scaled by
    random factors in [0.3, 3)."""
    rng = np.random.default_rng(1)
    variants = []
    for _ in range(count):
        v = copy.deepcopy(raw)
        v["piston"]["mass"] = scene.cylinders[0].piston.mass * rng.uniform(0.3, 3)
        v["rod"]["mass"] = scene.cylinders[0].rod.mass * rng.uniform(0.3, 3)
        if inertia:
            v["rod"]["inertia"] = scene.cylinders[0].rod.inertia * rng.uniform(0.3, 3)
        variants.append(hb.load_scene(v))
    return variants


def _assert_equals_design(out, i, scene, huge=False):
    """Variant i of design_variants against hb.design and order_phasors of its
    designed scene. With ``huge``, the tolerances grow with the largest designed
    unbalance where it exceeds the force scale: its round-off is then the larger."""
    d = hb.design(scene)
    ds = d.dataset
    unit = evaluate(scene)
    unbalance = ds.unbalance.values * np.exp(1j * ds.unbalance_angle.values)
    grow = max(1.0, np.abs(unbalance).max() / unit.force_scale) if huge else 1.0
    force_scale, moment_scale = grow * unit.force_scale, grow * unit.moment_scale
    np.testing.assert_allclose(out["unbalance"][i], unbalance, rtol=0, atol=RTOL * force_scale, err_msg="unbalance")

    scale = np.where(ds.component_units.values == "N", force_scale, moment_scale)
    predicted = ds.predicted.values / scene.speeds[0] ** 2
    differ = out["cancelled"][i] != ds.cancelled.values
    if huge:
        # Next to huge unbalances "cancelled" is a threshold on their round-off, which other CPUs' BLAS kernels
        # round differently: the two may disagree only where the residual is within that round-off.
        differ &= np.abs(predicted) > RTOL * scale
    assert not differ.any(), ("cancelled", out["cancelled"][i], ds.cancelled.values)
    assert (np.abs(out["residual"][i] - predicted) <= RTOL * scale).all(), "residual"

    verified = order_phasors(evaluate(d.scene))
    np.testing.assert_allclose(out["force"][i], verified.force, rtol=0, atol=RTOL * force_scale, err_msg="force")
    np.testing.assert_allclose(out["moment"][i], verified.moment, rtol=0, atol=RTOL * moment_scale, err_msg="moment")
    return d


@pytest.mark.parametrize("name, edit", [
    ("test-single", None),  # balance-factor counterweights and a ±1× Lanchester pair
    ("inline-3", _with_throw_unbalance),  # free counterweights and a −1× moment shaft
    ("v6-90-split-pin", None),
    ("inline-4", None),  # a ±2× Lanchester pair
])
def test_variants_equal_the_design_of_each(name, edit):
    raw = _raw(name)
    raw = edit(raw) if edit else raw
    out, variants, (force, moment, force_low, force_high, moment_low, moment_high) = _designs(raw, 10, len(name))
    assert out["unbalance"].shape == (10, len(hb.design(variants[0]).dataset.element))
    for i, scene in enumerate(variants):
        _assert_equals_design(out, i, scene)
        # design's scales, from the variant's own evaluation, and the bounds that spare computing them
        unit = evaluate(scene)
        np.testing.assert_allclose([force[i], moment[i]], [unit.force_scale, unit.moment_scale], rtol=1e-14, atol=0)
        assert force_low[i] <= force[i] * (1 + 1e-15) and force[i] <= force_high[i] * (1 + 1e-15)
        assert moment_low[i] <= moment[i] * (1 + 1e-15) and moment[i] <= moment_high[i] * (1 + 1e-15)


def test_a_nearly_rank_deficient_shaft_follows_design_on_both_sides_of_the_cutoff():
    # A couple shaft with planes 2.5e-8 mm apart: its moment is within a few times design's
    # rank cutoff (1e-10 of the weighted matrix's norm). The cutoff mixes the force and moment
    # weights, so heavier rod inertias (a larger moment scale) make design drop the shaft as
    # round-off, lighter ones solve for it, with unbalances of 1e8 times the engine's own, which
    # design refuses as ill-conditioned (balance/sanity.py). The map holds the nominal scene's
    # decision; the variants that could decide otherwise are solved directly, and refused as design
    # refuses them.
    raw = _raw("inline-3")
    raw["design"]["moment_shaft"][0]["planes"] = ["0 mm", "2.5e-8 mm"]
    scene = hb.load_scene(copy.deepcopy(raw))
    dbasis = design_basis(scene, linear_phasors(scene))
    dropped, kept = [], []
    for inertia in (0.3, 1.0, 10.0, 30.0):
        for piston in (0.2, 1.0, 5.0):
            v = copy.deepcopy(raw)
            v["rod"]["inertia"] = scene.cylinders[0].rod.inertia * inertia
            v["piston"]["mass"] = scene.cylinders[0].piston.mass * piston
            variant = hb.load_scene(v)
            try:
                hb.design(variant)
            except DesignError as exc:
                assert "ill-conditioned" in str(exc) and "planes" in str(exc), exc
                kept.append(variant)
            else:
                dropped.append(variant)
    assert dropped and kept
    slots = np.array([slot_values(v)[1] for v in dropped])
    out = design_variants(dbasis, slots)
    assert (np.abs(out["unbalance"][:, -1]) < 1e-6).all()
    for i, v in enumerate(dropped):
        _assert_equals_design(out, i, v, huge=True)
    for v in kept:
        with pytest.raises(DesignError, match="ill-conditioned"):
            design_variants(dbasis, slot_values(v)[1][None])


def test_a_residual_at_the_balanced_tolerance_is_judged_by_the_variants_own_scale():
    # Throw 3 of the inline three 6e-8° off its regular star leaves an order-2 roll moment near
    # BALANCED_RTOL of the moment scale, which no counterweight acts on. The moment scale's cheap
    # bounds (a factor ~1.7 apart) straddle that tolerance for some variants, whose scales are then
    # computed as design computes them; the shared masses scaled alike keep the star regular.
    raw = _raw("inline-3")
    raw["cylinder"][2]["throw"] = "120.00000006 deg"
    raw["design"] = {"orders": [2], "cancel": ["roll"], "counterweights": [{"planes": ["-120 mm", "120 mm"]}]}
    scene = hb.load_scene(copy.deepcopy(raw))
    basis = linear_phasors(scene)
    variants = _mass_variants(raw, scene, 12, inertia=True)
    slots = np.array([slot_values(v)[1] for v in variants])
    dbasis = design_basis(scene, basis)
    out = design_variants(dbasis, slots)
    _, _, moment_low, moment_high = _scale_bounds(dbasis.bounds, slots)
    roll = np.abs([hb.design(v).dataset.predicted.values[0, 4] / v.speeds[0] ** 2 for v in variants])
    straddled = (roll > 1e-10 * moment_low) & (roll <= 1e-10 * moment_high)
    assert straddled.any() and out["cancelled"][:, 0, 4].any() and not out["cancelled"][:, 0, 4].all()
    for i, v in enumerate(variants):
        _assert_equals_design(out, i, v)


def test_unbalances_too_small_to_write_are_left_out_of_the_residual_phasors():
    # Throw 3 5e-7° off leaves an order-2 force that a ±2× pair cancels with unbalances near
    # BALANCED_RTOL of the force scale: design writes them for some variants and leaves them out
    # (and their force in the verified residual) for others.
    raw = _raw("inline-3")
    raw["cylinder"][2]["throw"] = "120.0000005 deg"
    raw["design"] = {"orders": [2], "cancel": ["force"], "lanchester_pair": [{
        "label": "pair", "order": 2, "axial_position": "0 mm", "heights": ["-100 mm", "-100 mm"],
        "lateral": ["50 mm", "-50 mm"]}]}
    scene = hb.load_scene(copy.deepcopy(raw))
    variants = _mass_variants(raw, scene, 8)
    out = design_variants(design_basis(scene, linear_phasors(scene)), np.array([slot_values(v)[1] for v in variants]))
    written = [len(_assert_equals_design(out, i, v).elements) for i, v in enumerate(variants)]
    assert 0 in written and 2 in written


def test_the_map_of_one_variant_serves_another():
    # The basis built from one variant, applied to the nominal scene.
    raw = _raw("test-single")
    other = hb.load_scene(_variant(raw, np.random.default_rng(3)))
    scene = hb.load_scene(raw)
    out = design_variants(design_basis(other, linear_phasors(other)), slot_values(scene)[1][None])
    assert not out["direct"].any()
    _assert_equals_design(out, 0, scene)


def test_orders_select_the_residual_phasors():
    scene = hb.load_scene(ENGINES / "inline-4.toml")
    basis = linear_phasors(scene)
    dbasis = design_basis(scene, basis)
    every = design_variants(dbasis, basis.values[None])
    some = design_variants(dbasis, basis.values[None], orders=[2, 4])
    np.testing.assert_array_equal(some["force"], every["force"][..., [2, 4]])
    np.testing.assert_array_equal(some["moment"], every["moment"][..., [2, 4]])


@pytest.mark.parametrize("name, match", [
    ("tractor-3cyl-balanced", "objective = \"peak\""),
    ("lever-single", "lever"),
])
def test_non_linear_designs_are_refused(name, match):
    scene = hb.load_scene(ENGINES / f"{name}.toml")
    basis = linear_phasors(scene.with_effects(scene.model.effects - {"balancers"}))
    with pytest.raises(DesignError, match=match) as info:
        design_basis(scene, basis)
    assert scene.source in str(info.value)
