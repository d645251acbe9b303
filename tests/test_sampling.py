"""Accuracy as a user setting: the sampling harmbal chooses for a target
accuracy, the accuracy it reports, and the warning when the orders asked for
are not resolved. The oracle is the 50-digit reference (harmbal.reference)."""

import warnings

import numpy as np
import pytest

import harmbal as hb
from harmbal.bench import engine_scene, relative_errors
from harmbal.reference import reference_phasors


def _scene(name, lam, **sampling):
    import dataclasses

    scene = engine_scene(name, lam)
    return dataclasses.replace(scene, sampling=dataclasses.replace(scene.sampling, **sampling))


@pytest.mark.parametrize("name", ["single", "V8"])
@pytest.mark.parametrize("lam", [0.25, 0.7, 0.9, 0.95])
@pytest.mark.parametrize("accuracy", [1e-3, 1e-8, 1e-12])
def test_target_accuracy_is_reached_and_reported_honestly(name, lam, accuracy):
    scene = _scene(name, lam, accuracy=accuracy, samples_per_rev=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the target is met: no warning
        orders = hb.order_spectrum(hb.simulate(scene))
    reference = reference_phasors(scene, scene.sampling.max_order)
    error = max(relative_errors(orders.force.values, orders.moment.values, reference))
    assert error <= max(accuracy, 1e-14)
    assert orders.attrs["accuracy_target"] == accuracy
    # The accuracy reported (relative to harmbal's own scales, the sums of the single bodies'
    # peak loads) bounds the true error on those scales and meets the target.
    on_own_scales = max(np.abs(orders[q].values - getattr(reference, q)).max() / float(orders[f"{q}_scale"])
                        for q in ("force", "moment"))
    assert on_own_scales <= orders.attrs["accuracy_reached"] <= accuracy


def test_default_is_near_machine_precision_at_ordinary_lambda():
    scene = _scene("V8", 0.3)
    orders = hb.order_spectrum(hb.simulate(scene))
    reference = reference_phasors(scene, scene.sampling.max_order)
    # relative to the load scale: round-off (1.1e-15 seen), with room for another CPU's
    assert max(relative_errors(orders.force.values, orders.moment.values, reference)) < 2e-14
    assert orders.attrs["samples_per_rev"] <= 64


def test_unresolved_orders_warn_with_the_estimate():
    scene = _scene("single", 0.5, samples_per_rev=16, accuracy=None, max_order=4)
    with pytest.warns(hb.AccuracyWarning, match="16 samples per revolution.*orders up to 4 are not resolved"):
        orders = hb.order_spectrum(hb.simulate(scene))
    reference = reference_phasors(scene, 4)
    error = max(np.abs(orders[q].values - getattr(reference, q)).max() / float(orders[f"{q}_scale"])
                for q in ("force", "moment"))
    assert 1e-6 < error <= orders.attrs["accuracy_reached"]
    assert orders.attrs["accuracy_target"] == 0.0


def test_resolved_fixed_sampling_does_not_warn():
    scene = _scene("single", 0.3, samples_per_rev=128, accuracy=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        orders = hb.order_spectrum(hb.simulate(scene))
    assert orders.attrs["accuracy_reached"] < 1e-14
    assert np.isfinite(orders.force.values).all()


@pytest.mark.parametrize("name", ["single", "I4", "V8", "W24"])
def test_reported_aliasing_bounds_the_true_error(name):
    """Per axis, the aliasing estimate of the order Dataset is at least the
    true error against the reference, over λ and targets (W24: the cylinders
    cancel its moment in the sampled tail band but not in the orders that fold
    back, which the body-by-body estimate sees)."""
    for lam in (0.25, 0.45, 0.7, 0.9, 0.95):
        for accuracy in (1e-3, 1e-6, 1e-10, 1e-14):
            scene = _scene(name, lam, accuracy=accuracy, samples_per_rev=None)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", hb.AccuracyWarning)
                orders = hb.order_spectrum(hb.simulate(scene))
            reference = reference_phasors(scene, scene.sampling.max_order)
            for quantity in ("force", "moment"):
                error = np.abs(orders[quantity].values - getattr(reference, quantity)).max(axis=0)
                assert np.all(error <= orders[f"aliasing_error_{quantity}"].values), (lam, accuracy, quantity)


def test_a_fast_shaft_in_the_tail_band_is_not_taken_for_aliasing():
    """A balance shaft is one harmonic: at 20× it stands in the tail band of
    the 48 samples a 12-order scene gets, yet folds onto no order kept
    (48 − 20 > 12). The aliasing estimate must not read its line as a slowly
    decaying tail (it did: an AccuracyWarning with an estimated error of 3.8,
    and a verification tolerance as large as the loads). Oracle: the same
    scene at 10× the samples, where the line is far from the tail band."""
    import dataclasses

    lanchester = hb.load_scene("datasets/engines/inline-4-lanchester.toml")
    shafts = tuple(dataclasses.replace(s, ratio=10 * s.ratio) for s in lanchester.shafts)
    scene = dataclasses.replace(lanchester, shafts=shafts, verify=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no AccuracyWarning
        orders = hb.order_spectrum(hb.simulate(scene))
    n = orders.attrs["samples_per_rev"]
    assert n // 4 < 20 <= n // 2 and n - 20 > scene.sampling.max_order  # the line is in the fitted band
    fine = hb.order_spectrum(hb.simulate(scene, samples_per_rev=10 * n))
    for q in ("force", "moment"):
        error = np.abs(orders[q] - fine[q]).max().item() / orders[f"{q}_scale"].max().item()
        assert error <= orders.attrs["accuracy_reached"] <= 1e-13, q


@pytest.mark.parametrize("seed", range(4))
def test_one_spectrums_estimate_is_the_vectorised_one(seed):
    """The aliasing estimate of a single spectrum (computed in Python floats)
    against the same spectrum estimated among others (numpy, vectorised):
    the same to round-off, with and without the geometry's slowest rate,
    on decaying, flat-tailed and empty tail bands."""
    from harmbal.orders.spectrum import aliasing_estimate

    rng = np.random.default_rng(seed)
    for case in range(300):
        samples = int(rng.integers(16, 3000))
        max_order = int(rng.integers(1, samples // 4))
        magnitudes = rng.uniform(0.2, 0.99) ** np.arange(samples // 2 + 1) * rng.uniform(0.5, 2, samples // 2 + 1)
        if case % 7 == 0:
            magnitudes[samples // 4:] = 0.0
        if case % 11 == 0:
            magnitudes[samples // 4:] = magnitudes[samples // 4]
        slowest = 0.0 if case % 2 else float(rng.uniform(0.1, 0.99))
        pair = np.stack([magnitudes, np.ones_like(magnitudes)])
        one = aliasing_estimate(magnitudes[None], samples, max_order, slowest)
        assert one.shape == (1,)
        # Round-off: the fitted rate's last bits, raised to a power below the sample count.
        expected = aliasing_estimate(pair, samples, max_order, slowest)[0]
        assert one[0] == pytest.approx(expected, rel=samples * 1e-15, abs=0)
