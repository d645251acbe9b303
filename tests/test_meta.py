"""Meta-tests: invariants of the code base itself (python-control style)."""

import dataclasses
import subprocess
import sys

import harmbal
from harmbal.scene import Cylinder
from harmbal.model.evaluate import PLACEMENT_FIELDS, TYPE_FIELDS


def test_cylinder_type_and_placement_cover_every_field():
    # The order-domain path groups cylinders by TYPE_FIELDS; a new Cylinder
    # field must be classified, or cylinders that differ in it would wrongly
    # share one spectrum.
    fields = {f.name for f in dataclasses.fields(Cylinder)}
    assert set(PLACEMENT_FIELDS) | set(TYPE_FIELDS) == fields
    assert not set(PLACEMENT_FIELDS) & set(TYPE_FIELDS)


def test_every_public_name_resolves_and_is_documented():
    for name in harmbal.__all__:
        value = getattr(harmbal, name)
        if name != "__version__":
            assert value.__doc__ and len(value.__doc__.strip()) > 20, name


def test_import_stays_light():
    code = ("import sys, harmbal; heavy = {'xarray', 'scipy', 'pint', 'matplotlib', 'dask', 'pyfftw', 'mpmath', 'h5netcdf'}; "
            "print(sorted(heavy & set(sys.modules)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_no_public_name_is_shadowed_by_a_submodule():
    # Importing a submodule sets it as an attribute of the package, which
    # would shadow a lazily exported function of the same name.
    import pkgutil

    submodules = {m.name for m in pkgutil.iter_modules(harmbal.__path__)}
    assert not submodules & set(harmbal.__all__)
