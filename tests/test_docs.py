"""Documentation is in step with the code: generated pages, documented signatures, console examples."""

import ast
import importlib
import importlib.util
import inspect
import re
import shlex
from pathlib import Path

import pytest

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
    mounts = {stem for stem in shipped if stem.endswith("-mounts")}  # on their mounts: docs/mounts.md
    classic = shipped - not_classic - designed - gas - mounts
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


# Console examples: what the docs show a command printing is what it prints.
#
# Every ```console block of README.md and docs/*.md is an example session. A line "$ harmbal ..." is a
# command (a trailing "# comment" is not part of it); the lines after it, up to the next "$" line, are
# what the doc shows it printing. The test runs each command with harmbal.cli.main, in a fresh folder
# per block where datasets/ is the repository's (so relative paths read as from the repository root and
# every file a command writes stays in the folder; an -o/--output/--plot target elsewhere is written
# there under its own name), and checks:
#
# - the exit status: 2 if the doc shows a "harmbal: error:" line, else 0;
# - the shown lines, compared line by line with runs of whitespace and leading/trailing blanks ignored,
#   and blank lines left out on both sides: the shown lines must appear in the output (stdout, then
#   stderr) as consecutive lines, in order; a shown line "..." stands for any number of lines (the lines
#   around it need not be adjacent), and "…" inside a line for any text (timings, round-off). A doc may
#   show an excerpt: output before the first shown line and after the last is not checked. A command
#   shown without output is checked for its exit status only.
#
# Blocks without a "$ harmbal" line (output excerpts the prose introduces) are not run. Commands that
# need a file the prose describes instead of shipping it are given it by PROSE_FILES.

CONSOLE_BLOCK = re.compile(r"^```console\n(.*?)^```", re.M | re.S)

#: Commands slower than a few seconds (HTML reports, the accuracy study): their blocks are marked slow.
SLOW_COMMANDS = {"report", "bench"}

#: Options whose value is a file the command writes.
OUTPUT_OPTIONS = {"-o", "--output", "--plot"}


def _lever_far(root: Path) -> str:
    """docs/lever.md: the bundled lever scene with the pivot moved to (155, -45) mm."""
    text = (root / "datasets" / "engines" / "lever-single.toml").read_text(encoding="utf-8")
    pivot = re.compile(r'^pivot = \[.*\]', re.M)
    assert len(pivot.findall(text)) == 1, "docs/lever.md's lever-far.toml: lever-single.toml has no single pivot"
    return pivot.sub('pivot = ["155 mm", "-45 mm"]', text)


#: Files a doc's example uses that the prose describes: name -> its text from the repository root.
PROSE_FILES = {"lever-far.toml": _lever_far}


def _console_examples():
    """(doc, line, [(command argv, shown lines)]) of every console block with a harmbal command."""
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        for match in CONSOLE_BLOCK.finditer(text):
            session = []
            for line in match.group(1).splitlines():
                if line.startswith("$ "):
                    session.append((shlex.split(line[2:], comments=True), []))
                elif session:
                    session[-1][1].append(line)
            session = [(argv[1:], shown) for argv, shown in session if argv and argv[0] == "harmbal"]
            if session:
                yield path.relative_to(ROOT).as_posix(), text[:match.start()].count("\n") + 2, session


def _example_params():
    for doc, line, session in _console_examples():
        slow = any(argv[0] in SLOW_COMMANDS for argv, _ in session)
        yield pytest.param(session, id=f"{doc}:{line}", marks=[pytest.mark.slow] if slow else [])


def _normal(line: str) -> str:
    return " ".join(line.split())


def _chunks(shown: list[str]) -> list[list[re.Pattern]]:
    """The shown lines as runs of consecutive-line patterns, split at "..." lines (blank lines left out)."""
    chunks = [[]]
    for line in filter(None, map(_normal, shown)):
        if line == "...":
            chunks.append([])
        else:
            chunks[-1].append(re.compile(".*".join(map(re.escape, line.split("…")))))
    return [chunk for chunk in chunks if chunk]


def _find(chunks, printed: list[str]) -> str | None:
    """None if every run of ``chunks`` is in ``printed`` in order, else the first run that is not."""
    lines = list(filter(None, map(_normal, printed)))
    start = 0
    for chunk in chunks:
        for i in range(start, len(lines) - len(chunk) + 1):
            if all(p.fullmatch(lines[i + j]) for j, p in enumerate(chunk)):
                start = i + len(chunk)
                break
        else:
            return "\n".join(p.pattern for p in chunk)
    return None


def _in_folder(argv: list[str], renamed: dict[str, str], folder: Path) -> list[str]:
    """``argv`` with files written outside ``folder`` written inside it, and later uses of them renamed."""
    argv = [renamed.get(a, a) for a in argv]
    for i, option in enumerate(argv[:-1]):
        target = argv[i + 1]
        if option in OUTPUT_OPTIONS and not (folder / target).resolve().is_relative_to(folder.resolve()):
            renamed[target] = argv[i + 1] = Path(target).name
    return argv


def test_console_examples_are_found():
    sessions = list(_console_examples())
    assert len(sessions) >= 12
    shown = sum(bool(_chunks(s)) for _, _, session in sessions for _, s in session)
    assert shown >= 5, "console examples showing output"


@pytest.mark.parametrize("session", list(_example_params()))
def test_console_example_prints_what_the_doc_shows(session, tmp_path, monkeypatch, capsys):
    from harmbal.cli import main

    (tmp_path / "datasets").symlink_to(ROOT / "datasets", target_is_directory=True)
    for name, make in PROSE_FILES.items():
        (tmp_path / name).write_text(make(ROOT), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    renamed = {}
    for argv, shown in session:
        argv = _in_folder(argv, renamed, tmp_path)
        status = main(argv)
        captured = capsys.readouterr()
        printed = captured.out.splitlines() + captured.err.splitlines()
        command = "harmbal " + shlex.join(argv)
        expected = 2 if any(_normal(line).startswith("harmbal: error:") for line in shown) else 0
        assert status == expected, f"{command}: exit status {status}\n{captured.err}"
        missing = _find(_chunks(shown), printed)
        assert missing is None, (f"{command}: the doc shows\n{missing}\nwhich the output does not have:\n"
                                 + "\n".join(printed))
