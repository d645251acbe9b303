"""Every bundled scene loads, says where it comes from, and analyses to finite results."""

from pathlib import Path

import numpy as np
import pytest

import harmbal as hb

ENGINES = sorted((Path(__file__).parent.parent / "datasets" / "engines").glob("*.toml"))
REQUIRED = {
    "tractor-3cyl", "test-single", "single", "inline-twin-180", "inline-twin-270", "inline-twin-360",
    "inline-3", "inline-4", "inline-5", "inline-6", "v-twin-45", "v-twin-60", "v-twin-90", "boxer-twin",
    "flat-4", "v6-60", "v6-90-common-pin", "v6-90-split-pin", "v8-cross-plane", "v8-flat-plane", "v12",
}


def test_all_required_datasets_exist():
    assert REQUIRED <= {p.stem for p in ENGINES}


@pytest.mark.parametrize("path", ENGINES, ids=lambda p: p.stem)
def test_dataset_loads_and_analyses(path):
    assert path.read_text().startswith("#"), "each dataset starts with a comment saying what it is"
    tree = hb.analyse(hb.load_scene(path))
    orders = tree["orders"].ds
    for name in ("force", "moment", "force_rotating", "moment_rotating"):
        assert np.isfinite(orders[name].values).all()
    # The default sampling resolves the spectrum to round-off.
    assert float(orders.aliasing_error_force.max()) <= 1e-9 * float(orders.force_scale.max())


def test_tractor_first_order_moment_is_the_theses_value():
    """Reference engine A at 2460 rpm: the first-order counter-rotating moment of
    the reciprocating masses is √3/2·m_rec·r·ω²·a (1381.4 N m); the exact model
    with the 0.5 mm pin offset differs from it by less than 0.1 %."""
    scene = hb.load_scene(ENGINES[[p.stem for p in ENGINES].index("tractor-3cyl")])
    orders = hb.analyse(scene)["orders"].ds
    omega = 2460 * np.pi / 30
    m_rec = 2.0221 + 2.7447 * 72.34 / 215
    expected = np.sqrt(3) / 2 * m_rec * 0.060 * omega**2 * 0.136
    counter = abs(complex(orders.moment_rotating.sel(order=1, rotation="counter")))
    assert expected == pytest.approx(1381.4, abs=0.05)
    assert counter == pytest.approx(expected, rel=1e-3)
