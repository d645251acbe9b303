"""The fast unit parser of harmbal.scene.units against its oracle, pint itself.

The fast path must give the float pint gives, to the last bit, for every unit
string a scene can hold that it accepts, and must leave to pint (return None)
everything pint refuses or it does not know, so that errors keep pint's words.
"""

import random
import subprocess
import sys
import tomllib
from functools import lru_cache
from pathlib import Path

import pytest

from harmbal.scene import units
from harmbal.scene.units import _BASE, _DERIVED, _NAMES, _SI, SI_UNITS, QuantityError, _fast, to_si

pint = pytest.importorskip("pint")

ROOT = Path(__file__).resolve().parent.parent
DIMENSIONS = tuple(SI_UNITS)


@lru_cache(maxsize=1)
def registry():
    return pint.UnitRegistry()


def oracle(text: str, dimension: str | None = None):
    """What pint makes of ``text`` as a ``dimension`` (as each dimension if
    None): a float, or ("error", why) where harmbal refuses it."""
    ureg = registry()
    # pint caches conversion factors by the set of units, not by the order
    # they were written in; start each string afresh, as a new process would.
    ureg._cache.root_units.clear()
    ureg._cache.conversion_factor.clear()
    try:
        quantity = ureg.Quantity(text)
    except Exception:  # noqa: BLE001 - pint raises several types
        return ("error", "unreadable") if dimension else {d: ("error", "unreadable") for d in DIMENSIONS}
    results = {}
    for d in (dimension,) if dimension else DIMENSIONS:
        if d == "speed" and not any(name.startswith("revolutions_per_") or not ureg.get_dimensionality(name)
                                    for name, _ in quantity.unit_items()):
            results[d] = ("error", "ambiguous")
            continue
        if d == "frequency" and any(name.startswith("revolutions_per_") or not ureg.get_dimensionality(name)
                                    for name, _ in quantity.unit_items()):
            results[d] = ("error", "an angle per time")
            continue
        try:
            results[d] = float(quantity.to(SI_UNITS[d] or "dimensionless").magnitude)
        except pint.DimensionalityError:
            results[d] = ("error", "dimension")
    return results[dimension] if dimension else results


def same(a: float, b: float) -> bool:
    """Bit for bit, -0.0 and 0.0 told apart."""
    return a.hex() == b.hex()


def check(text: str) -> int:
    """Assert the fast path agrees with pint in every dimension; the number
    of dimensions it took the string in."""
    taken = 0
    for dimension, expected in oracle(text).items():
        got = _fast(text, dimension)
        if got is not None:
            assert isinstance(expected, float), (text, dimension, got, expected)
            assert same(got, expected), (text, dimension, got, expected)
            taken += 1
    return taken


def scene_strings() -> set[str]:
    found: set[str] = set()

    def walk(value):
        if isinstance(value, dict):
            for v in value.values():
                walk(v)
        elif isinstance(value, list):
            for v in value:
                walk(v)
        elif isinstance(value, str) and value[:1] in "-+.0123456789":  # a quantity, not a name ("u", an axis)
            found.add(value)

    for path in sorted((ROOT / "datasets" / "engines").glob("*.toml")):
        walk(tomllib.loads(path.read_text(encoding="utf-8")))
    return found


def doc_strings() -> set[str]:
    import re

    text = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    return {s for s in re.findall(r'"([-+.0-9][^"]*)"', text)}


# -- the tables are pint's ---------------------------------------------------


def test_names_are_what_pint_calls_them():
    for token, name in _NAMES.items():
        assert registry().get_name(token) == name, token


def test_definitions_are_pints():
    ureg = registry()
    for name in _NAMES.values():
        ureg.get_name(name)  # defines prefixed units on demand
    for name, dimension in _BASE.items():
        definition = ureg._units[name]
        assert definition.is_base, name
        assert dict(ureg.get_dimensionality(name)) == ({dimension: 1} if dimension else {}), name
    for name, (scale, reference) in _DERIVED.items():
        definition = ureg._units[name]
        assert not definition.is_base, name
        assert definition.converter.is_multiplicative, name
        assert type(definition.converter.scale) is type(scale) and definition.converter.scale == scale, name
        assert tuple((ureg.get_name(k), v) for k, v in definition.reference.items()) == reference, name
        for key, _ in reference:
            assert key in _BASE or key in _DERIVED, key


def test_si_units_are_parsed_as_pint_parses_them():
    for dimension, unit in SI_UNITS.items():
        container = pint.util.to_units_container(unit or "dimensionless", registry())
        assert tuple(container.items()) == _SI[dimension], dimension


# -- every string a bundled scene or the scene docs write ---------------------


def test_every_bundled_quantity_takes_the_fast_path_and_equals_pint():
    for text in sorted(scene_strings() | doc_strings()):
        for dimension, expected in oracle(text).items():
            got = _fast(text, dimension)
            if isinstance(expected, float):
                assert got is not None and same(got, expected), (text, dimension, got, expected)
            else:
                assert got is None, (text, dimension, got, expected)


def test_bundled_scenes_need_no_pint():
    code = ("import sys, warnings, glob; from harmbal.scene import load_scene; warnings.simplefilter('ignore'); "
            "[load_scene(p) for p in sorted(glob.glob('datasets/engines/*.toml'))]; print('pint' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT).stdout
    assert out.strip() == "False"


# -- generated combinations ----------------------------------------------------

NUMBERS = ["0", "1", "5", "12", "215", "2460", "26131", "-4", "+3", "-0", "0.5", ".5", "5.", "-0.0", "0.1", "0.3",
           "1e-12", "1E5", "2.5e-3", "1.5E+2", "3.3333333333333335", "0.0285", "123456789012345678901",
           "9007199254740993", "1e308", "1e400", "0123", "1_000", "00.5", "7e0"]


def expressions(rng: random.Random) -> list[str]:
    tokens = sorted(_NAMES) + ["Hz", "dimensionless", "lb", "kHz", "degC", "percent", "inf", "pi"]
    powers = ["", "^2", "^-1", "**2", "^ 2", " ^ -2", "^3", "^0", "^1", "**-1", "^+2", "^2.0", "^02"]
    joins = [" ", "*", " * ", "/", " / ", "  "]
    found = set(tokens)
    for token in tokens:
        for power in powers:
            found.add(token + power)
    for _ in range(2500):
        parts = [rng.choice(tokens) + rng.choice(powers[:6]) for _ in range(rng.randint(2, 4))]
        text = parts[0]
        for part in parts[1:]:
            text += rng.choice(joins) + part
        found.add(text)
    # and as many that have one of the scene's dimensions, in every spelling
    groups = {}
    for token, name in _NAMES.items():
        groups.setdefault(tuple(sorted(units._dimension(name).items())), []).append(token)
    length, mass = groups[(("[length]", 1),)], groups[(("[mass]", 1),)]
    time, angle = groups[(("[time]", 1),)], groups[()]
    rate, force = groups[(("[time]", -1),)], groups[(("[length]", 1), ("[mass]", 1), ("[time]", -2))]
    templates = [[length], [mass], [angle], [angle, "/", time], [angle, " ", time, "^-1"], [rate],
                 [mass, " ", length, "^2"], [length, "**2", "*", mass], [mass, " ", length, " ", length],
                 [mass, " * ", length, "^2 ", angle], [mass, " ", length], [length, " ", mass], [force],
                 [mass, " ", length, "/", time, "^2"], [force, " ", length], [length, "*", force],
                 [mass, " ", length, "^2/", time, "/", time], [angle, " / ", angle], [length, "/", length],
                 [angle, "^2"], [rate, " ", time], [time, " ", rate, " ", angle]]
    for _ in range(1500):
        template = rng.choice(templates)
        found.add("".join(rng.choice(part) if isinstance(part, list) else part for part in template))
    for si in SI_UNITS.values():
        found.add(si)
    found |= {"kg m^2", "kg mm^2", "g mm", "g mm^2", "kg cm^2", "N m", "kN mm", "rad/s", "deg/s", "turn/s",
              "turn/min", "rev/s", "1/s", "1/min", "rpm rad", "Hz rad", "deg/ms", "kg*m**2", "kg m/s^2",
              "g cm/s^2 m", "mm kg", "ft lb", "in^2 lb", "m²", "°", "kg·m", "mm per s", "mm squared"}
    return sorted(found)


def test_generated_quantities_equal_pint_bit_for_bit():
    rng = random.Random(20261124)
    taken = total = 0
    for expression in expressions(rng):
        for number in rng.sample(NUMBERS, 2):
            gap = rng.choice(["", " ", "  ", "*", " * "])
            total += len(DIMENSIONS)
            taken += check(f"{number}{gap}{expression}")
    assert taken > 3000, (taken, total)


def test_plain_numbers_and_odd_spellings():
    for text in ["40", "-7", "1e-12", "0.25", " 5 mm", "5 mm ", "5\tmm", "5 mm\n", "5,000 mm", "5 mm mm", "",
                 "mm", "5 5 mm", "- 5 mm", "--5 mm", "5 (mm)", "5 mm)", "5e mm", "1e3mm", "5 em", "1j mm",
                 "5 mm/", "5 mm*", "5 /s", "5 m^", "5 m^x", "5 m2", "5 kg_m", "0x10 mm", "5 mm # x"]:
        check(text)


# -- the refusals stay pint's ------------------------------------------------------


@pytest.mark.parametrize("text", ["50 Hz", "50 1/s", "3000 1/min", "50 hertz", "50 kHz", "50"])
def test_ambiguous_speeds_are_refused(text):
    assert _fast(text, "speed") is None
    with pytest.raises(QuantityError, match="ambiguous for a rotational speed"):
        units._parse_string.__wrapped__(text, "speed")


@pytest.mark.parametrize(("text", "dimension", "message"), [
    ("0.45 m", "mass", "has units m but [mass] (e.g. kg) is expected"),
    ("40", "length", "has no units but [length] (e.g. m) is expected"),
    ("5 kg mm", "inertia", "has units kg * mm but [inertia] (e.g. kg m^2) is expected"),
    ("3000 rpm", "length", "has units rpm but [length] (e.g. m) is expected"),
    ("2 mm", "dimensionless", "has units mm but dimensionless is expected"),
])
def test_wrong_dimensions_keep_pints_message(text, dimension, message):
    assert _fast(text, dimension) is None
    with pytest.raises(QuantityError) as info:
        to_si(text, dimension)
    assert str(info.value) == message


def test_unreadable_strings_keep_pints_message():
    with pytest.raises(QuantityError, match=r"cannot read 'abc mm' as a quantity"):
        to_si("abc mm", "length")
    with pytest.raises(QuantityError, match="must be finite"):
        to_si("1e400 mm", "length")
