"""Generated documentation is in step with the code."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_layouts_page_is_what_the_generator_writes():
    expected = _load("make_layouts").page()
    committed = (ROOT / "docs" / "layouts.md").read_text(encoding="utf-8")
    assert committed == expected, "docs/layouts.md is stale: run python docs/make_layouts.py"


def test_every_classic_dataset_has_a_worked_example():
    layouts = _load("make_layouts").LAYOUTS
    shipped = {p.stem for p in (ROOT / "datasets" / "engines").glob("*.toml")}
    # Reference engines and special scenes are documented elsewhere; a new
    # classic layout must get a worked example or be listed here.
    not_classic = {"tractor-3cyl", "tractor-3cyl-balanced", "test-single", "single", "w24-broad-arrow",
                   "lever-single"}  # lever balancers: docs/lever.md
    # Designed variants are documented in docs/design.md.
    spec = importlib.util.spec_from_file_location("make_balanced", ROOT / "datasets" / "make_balanced.py")
    make_balanced = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_balanced)
    designed = {name for name, _ in make_balanced.VARIANTS.values()}
    gas = {stem for stem in shipped if stem.endswith("-gas")}  # cylinder pressure: docs/gas.md
    classic = shipped - not_classic - designed - gas
    assert classic <= set(layouts), sorted(classic - set(layouts))
    assert set(layouts) <= shipped
