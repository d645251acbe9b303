"""Documentation is in step with the code: generated pages, documented signatures."""

import ast
import importlib
import importlib.util
import inspect
import re
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


#: A documented call: a dotted name from ``hb.`` or ``harmbal.`` and its parameter list, in backticks.
_CALL = re.compile(r"`((?:hb|harmbal)\.[A-Za-z_][\w.]*)\(([^`]*)\)`")


def _documented_parameters(text: str) -> list[str]:
    """The parameters of a documented parameter list, split at top-level commas."""
    parts, depth, current = [], 0, ""
    for char in text:
        depth += char in "([{"
        depth -= char in ")]}"
        if char == "," and depth == 0:
            parts.append(current.strip())
            current = ""
        else:
            current += char
    return [p for p in parts + [current.strip()] if p]


def _resolve(dotted: str):
    module_name, _, attr = dotted.replace("hb.", "harmbal.", 1).rpartition(".")
    module = importlib.import_module(module_name)
    return getattr(module, attr)


def test_the_documented_signatures_are_the_code_s():
    """Every call written as ``hb.name(parameters)`` in docs/api.md names only parameters the function has,
    with the defaults it has (a signature that changed without its documentation fails here)."""
    text = (ROOT / "docs" / "api.md").read_text()
    checked = 0
    for name, arguments in _CALL.findall(text):
        if "…" in arguments or "..." in arguments or "[" in arguments or "(" in arguments.split("=")[0]:
            continue  # an example or an elided list, not a signature
        signature = inspect.signature(_resolve(name))
        for parameter in _documented_parameters(arguments):
            if parameter == "*" or parameter.startswith("{"):
                continue  # keyword-only marker; a placeholder for a mapping the text explains
            key, _, default = parameter.partition("=")
            key = key.strip().lstrip("*")
            assert key in signature.parameters, f"docs/api.md: {name}() has no parameter {key!r}"
            if default:
                actual = signature.parameters[key].default
                assert ast.literal_eval(default.strip()) == actual, (
                    f"docs/api.md: {name}({key}=...) defaults to {actual!r}, not {default.strip()}")
        checked += 1
    assert checked >= 30
