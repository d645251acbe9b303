"""The bad-input corpus (issue 32) through every command that reads a scene.

Each case of ``tests/corpus.py`` is run by each command it applies to, in a
subprocess limited to :data:`corpus.MEMORY_LIMIT` of address space and
:data:`corpus.CASE_SECONDS` per case. Every run must end in a refusal: the
case's exit code, ``harmbal: error:`` lines only (no traceback, nothing
escaping ``main``), the scene file and the case's key named, and nothing
written next to the outputs asked for.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import corpus  # noqa: E402

CASES = {case.name: case for case in corpus.cases()}
PAIRS = [(command, name) for command in corpus.COMMANDS for name, case in CASES.items() if command in case.commands]


def test_the_corpus_is_large_and_covers_every_category():
    assert len(CASES) == len(corpus.cases()) >= 100  # names are unique
    assert {case.category for case in CASES.values()} >= {
        "file", "strings", "structure", "ranges", "firing", "gas", "traces", "balancers", "requests", "work", "sweep"}


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    """The runs of one command over its cases, each case built in a folder
    of its own, all in one subprocess (run once per command, on first use)."""
    root = tmp_path_factory.mktemp("corpus")
    found: dict[str, dict[str, dict]] = {}

    def of(command: str) -> dict[str, dict]:
        if command not in found:
            found[command] = {r["name"]: r for r in run_command(command, root)}
        return found[command]
    return of


def run_command(command: str, root: Path, names=None) -> list[dict]:
    """Build the cases of ``command`` (all, or those ``names``) under
    ``root`` and run them."""
    jobs = []
    for name, case in CASES.items():
        if command not in case.commands or (names is not None and name not in names):
            continue
        folder = root / command / name
        out = folder / "out"
        out.mkdir(parents=True)
        scene = case.build(folder)
        jobs.append({"name": name, "argv": case.argv(command, scene, out), "scene": str(scene), "out": str(out)})
    return _run(command, jobs, root)


def _run(command: str, jobs: list[dict], root: Path) -> list[dict]:
    results: list[dict] = []
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONFAULTHANDLER": "1"}
    while len(results) < len(jobs):
        remaining = jobs[len(results):]
        jobs_file, results_file = root / f"{command}.jobs.json", root / f"{command}.results.jsonl"
        jobs_file.write_text(json.dumps(remaining))
        results_file.write_text("")
        timeout = corpus.CASE_SECONDS * len(remaining) + 60
        done = subprocess.run([sys.executable, str(Path(corpus.__file__)), command, str(jobs_file), str(results_file)],
                              capture_output=True, text=True, timeout=timeout, env=env)
        lines = [json.loads(line) for line in results_file.read_text().splitlines()]
        results += lines
        if len(lines) < len(remaining):  # the process died on the next case
            results.append({"name": remaining[len(lines)]["name"], "exit": done.returncode,
                            "stderr": done.stderr[-2000:], "stdout": "",
                            "escaped": f"the process died (exit {done.returncode})", "seconds": None})
    for result, job in zip(results, jobs):
        result["out"], result["scene"] = job["out"], job["scene"]
    return results


@pytest.mark.parametrize("command, name", PAIRS)
def test_bad_input_is_refused_in_one_message_naming_file_and_key(outcomes, command, name):
    case, result = CASES[name], outcomes(command)[name]
    assert result["escaped"] is None, result["escaped"]
    assert "Traceback" not in result["stderr"], result["stderr"]
    assert result["exit"] == case.exit, (result["exit"], result["stderr"], result["stdout"][-500:])
    errors = [line for line in result["stderr"].splitlines()  # ours, or argparse's "harmbal sweep: error:"
              if line.startswith("harmbal") and ": error: " in line]
    assert errors, result["stderr"]
    message = "\n".join(errors)
    assert case.key in message, message
    if case.names_file:
        assert Path(result["scene"]).name in message, message
    assert not os.listdir(result["out"]), os.listdir(result["out"])
