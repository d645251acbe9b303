"""The accuracy-against-cost benchmark (harmbal.bench, `harmbal bench`).

The errors it reports are checked for what the mathematics says they must
be: the exact model at the default sampling is at round-off against the
50-digit reference; too few samples per revolution or a truncated piston
series are not; each series is better than the shorter one; the error falls
as the sampling grows until it reaches round-off.
"""

import csv

import pytest

from harmbal import bench
from harmbal.cli import main


@pytest.fixture(scope="module")
def rows():
    return bench.run(["single"], [0.45], budget=1e-4, repeat=1)


def _row(rows, family, setting):
    return next(r for r in rows if r["family"] == family and r["setting"] == setting)


def test_exact_paths_are_at_round_off(rows):
    for family, setting in (("piston", "exact"), ("rod", "rigid"), ("path", "order domain"), ("path", "time domain"),
                            ("path", "time domain, Datasets"), ("accuracy", "1e-12"), ("samples", "4096/rev")):
        assert _row(rows, family, setting)["error"] < 1e-14, (family, setting)
    for r in rows:
        if r["family"] == "fft":
            assert r["error"] < 1e-14, r["setting"]


def test_approximations_show_their_error(rows):
    series = [_row(rows, "piston", f"series {h}")["error"] for h in bench.SERIES_HARMONICS]
    assert series[0] > series[1] > series[2] > 1e-8
    assert series[0] > 1e-3
    assert _row(rows, "rod", "two_point")["error"] > 1e-4
    samples = [_row(rows, "samples", f"{n}/rev")["error"] for n in bench.SAMPLES]
    assert samples[0] > 1e-2 and samples[-1] < 1e-14
    first_exact = next(i for i, e in enumerate(samples) if e < 1e-14)
    assert all(a > b for a, b in zip(samples[:first_exact], samples[1:first_exact + 1]))


def test_accuracy_setting_is_met(rows):
    for accuracy in bench.ACCURACIES:
        row = _row(rows, "accuracy", f"{accuracy:g}")
        assert row["error"] <= max(accuracy, 1e-14), row
        assert row["seconds"] > 0


def test_rows_carry_every_column(rows):
    assert all(set(r) == set(bench.COLUMNS) for r in rows)
    assert {r["family"] for r in rows} == set(bench.FAMILIES)
    table = bench.to_markdown(rows)
    assert "### single (1 cylinder)" in table and "λ = 0.45: error, time" in table


def test_cli_bench_writes_table_csv_and_figure(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench", "-o", str(out), "--quick", "--engines", "V8", "--lambdas", "0.7",
                 "--families", "path,piston"]) == 0
    printed = capsys.readouterr()
    assert "### V8 (8 cylinders)" in printed.out and "reference (mpmath, 50 digits" in printed.err
    assert sorted(p.name for p in out.iterdir()) == ["accuracy.csv", "accuracy.md", "accuracy.svg"]
    with open(out / "accuracy.csv", encoding="utf-8") as fh:
        read = list(csv.DictReader(fh))
    assert {r["family"] for r in read} == {"path", "piston"}
    assert float(next(r for r in read if r["setting"] == "order domain")["error"]) < 1e-14
    assert (out / "accuracy.svg").read_text(encoding="utf-8").lstrip().startswith("<?xml")


@pytest.mark.parametrize("args", [["--engines", "V9"], ["--lambdas", "0.99"], ["--lambdas", "x"],
                                  ["--families", "paths"]])
def test_cli_bench_bad_arguments_exit_2(tmp_path, args, capsys):
    with pytest.raises(SystemExit) as info:
        main(["bench", "-o", str(tmp_path / "b"), *args])
    assert info.value.code == 2
    assert not (tmp_path / "b").exists()


def test_cli_bench_output_must_be_a_folder(tmp_path, capsys):
    (tmp_path / "file").write_text("x", encoding="utf-8")
    assert main(["bench", "-o", str(tmp_path / "file"), "--quick", "--engines", "single"]) == 2
    assert "not a folder" in capsys.readouterr().err
