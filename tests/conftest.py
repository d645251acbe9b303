import copy

import numpy as np
import pytest

#: A small valid scene (SI numbers) that tests modify to provoke one problem at a time.
BASE_SCENE = {
    "engine": {"name": "twin", "speed": "3000 rpm", "rotation": "clockwise"},
    "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm", "pin_offset": "0.5 mm"},
    "piston": {"mass": "0.45 kg"},
    "rod": {"mass": "0.5 kg", "cg_from_big_end": "40 mm", "inertia": "0.0012 kg m^2"},
    "cylinder": [
        {"throw": "0 deg", "axial_position": "45 mm"},
        {"throw": "180 deg", "axial_position": "-45 mm"},
    ],
}


@pytest.fixture
def base_scene():
    return copy.deepcopy(BASE_SCENE)


def assert_close_to_scale(actual, expected, scale, rtol=1e-12, err_msg=""):
    """Assert that ``actual`` equals ``expected`` to ``rtol`` of the quantity's physical ``scale``.

    Two computations that agree to round-off differ by round-off *of the scale* (a load scale, the
    largest component, the input's magnitude), and by different round-off on another CPU or BLAS
    build: a component that cancels is round-off itself and has no relative error of its own, and an
    absolute number near round-off has no margin. So the test is |actual − expected| ≤ rtol·scale,
    element by element; ``scale`` broadcasts (one per variant, per component, ...) and must be > 0.
    The default 1e-12 is the suite's tolerance for results that are exact (docs/conventions.md,
    "Tolerances in the tests")."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    scale = np.asarray(scale, dtype=float)
    assert actual.shape == expected.shape, f"{err_msg} shapes {actual.shape} and {expected.shape}"
    assert np.all(scale > 0) and np.all(np.isfinite(scale)), f"{err_msg} scale {scale} must be positive"
    error = np.abs(actual - expected)
    tolerance = rtol * scale
    bad = ~(error <= tolerance)  # NaN fails too
    if bad.any():
        relative = np.nan_to_num(np.broadcast_to(error / scale, error.shape), nan=np.inf)
        worst = np.unravel_index(np.argmax(np.where(bad, relative, -1.0)), error.shape)
        raise AssertionError(f"{err_msg}\n{np.count_nonzero(bad)} of {error.size} elements differ by more than "
                             f"rtol={rtol:g} of their scale; worst at {tuple(int(i) for i in worst)}: "
                             f"{actual[worst].item()} vs {expected[worst].item()}, "
                             f"|difference| / scale = {relative[worst]:.3g}")
