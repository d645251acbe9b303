"""Scene files are read safely and output targets are checked before any work
(issue 32, first part): regular files only, a size limit, UTF-8 with or
without a byte-order mark, and no output onto a directory, the input scene or
an unwritable folder. Every refusal exits 2 with one line naming the file and
writes nothing."""

import os
import shutil
from pathlib import Path

import pytest

import harmbal as hb
from harmbal.cli import main
from harmbal.scene.reader import MAX_SCENE_BYTES

ROOT = Path(__file__).resolve().parent.parent
TRACTOR = ROOT / "datasets" / "engines" / "tractor-3cyl.toml"


def _error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("harmbal: error: "), err
    return err[0]


def test_a_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + TRACTOR.read_bytes())
    assert hb.load_scene(path).name == hb.load_scene(TRACTOR).name


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16"])
def test_other_encodings_are_refused_saying_to_save_as_utf8(tmp_path, capsys, encoding):
    path = tmp_path / "engine.toml"
    path.write_bytes(TRACTOR.read_text(encoding="utf-8").replace("tractor", "tractør").encode(encoding, "replace"))
    assert main(["run", str(path)]) == 2
    line = _error(capsys)
    assert str(path) in line and "save it as UTF-8" in line


def test_a_binary_file_is_refused(tmp_path, capsys):
    path = tmp_path / "engine.toml"
    path.write_bytes(bytes(range(256)) * 4)
    assert main(["run", str(path)]) == 2
    assert str(path) in _error(capsys)


def test_a_directory_is_refused(tmp_path, capsys):
    assert main(["run", str(tmp_path)]) == 2
    line = _error(capsys)
    assert str(tmp_path) in line and "directory" in line


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_without_blocking(tmp_path, capsys):
    fifo = tmp_path / "engine.toml"
    os.mkfifo(fifo)
    assert main(["run", str(fifo)]) == 2  # opening a FIFO for reading would block forever
    assert "not a regular file" in _error(capsys)


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero here")
def test_a_device_is_refused_without_reading_it(capsys):
    assert main(["run", "/dev/zero"]) == 2
    assert "not a regular file" in _error(capsys)


def test_an_oversized_file_is_refused(tmp_path, capsys):
    path = tmp_path / "engine.toml"
    path.write_text(TRACTOR.read_text(encoding="utf-8") + "#" * MAX_SCENE_BYTES, encoding="utf-8")
    assert main(["run", str(path)]) == 2
    assert "larger than" in _error(capsys)


def _copy(tmp_path) -> Path:
    scene = tmp_path / "engine.toml"
    shutil.copy(TRACTOR, scene)
    return scene


def test_run_does_not_overwrite_its_scene(tmp_path, capsys):
    scene = _copy(tmp_path)
    before = scene.read_bytes()
    assert main(["run", str(scene), "-o", str(scene)]) == 2
    assert "would overwrite the input scene" in _error(capsys)
    assert scene.read_bytes() == before


@pytest.mark.parametrize("command", [["run"], ["loads"], ["report"]])
def test_an_output_onto_a_directory_is_refused_before_any_work(tmp_path, capsys, command):
    scene = _copy(tmp_path)
    target = tmp_path / ("out.html" if command == ["report"] else "out.nc")
    target.mkdir()
    assert main([*command, str(scene), "-o", str(target)]) == 2
    assert "is a directory" in _error(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["engine.toml", target.name]


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root may write anywhere")
def test_an_unwritable_folder_is_refused_before_any_work(tmp_path, capsys):
    scene = _copy(tmp_path)
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        assert main(["run", str(scene), "-o", str(folder / "out.nc")]) == 2
        assert "not writable" in _error(capsys)
    finally:
        folder.chmod(0o700)


def _named(tmp_path, name: str) -> Path:
    scene = tmp_path / "engine.toml"
    text = TRACTOR.read_text(encoding="utf-8")
    scene.write_text(text.replace('name = "tractor-3cyl"', f"name = {name}", 1), encoding="utf-8")
    assert text.count('name = "tractor-3cyl"') == 1
    return scene


@pytest.mark.parametrize("name, rule", [('"a\\u0000b"', "control character U+0000"),
                                        ('"two\\nlines"', "one line"), ('"   "', "must not be empty"),
                                        ('"' + "x" * 201 + '"', "at most 200 characters")])
def test_names_are_one_line_of_printable_text(tmp_path, capsys, name, rule):
    scene = _named(tmp_path, name)
    assert main(["run", str(scene), "-o", str(tmp_path / "out.nc")]) == 2
    line = _error(capsys)
    assert "engine.name" in line and rule in line
    assert not (tmp_path / "out.nc").exists()


def test_a_label_with_a_control_character_names_its_key(tmp_path):
    scene = _named(tmp_path, '"ok"')
    scene.write_text(scene.read_text(encoding="utf-8") + '\n[[balance_shaft]]\nlabel = "bad\\u0007"\nratio = -1\n'
                     'unbalance = { unbalance = "1 kg mm", angle = "0 deg" }\n', encoding="utf-8")
    with pytest.raises(hb.SceneError) as info:
        hb.load_scene(scene)
    assert any(p.key == "balance_shaft[1].label" and "U+0007" in p.rule for p in info.value.problems)


def test_mathtext_in_a_name_is_drawn_as_written(tmp_path, capsys):
    scene = _named(tmp_path, "'a $\\foo$ engine'")
    report, plot = tmp_path / "r.html", tmp_path / "s.svg"
    assert main(["report", str(scene), "-o", str(report)]) == 0
    assert main(["stars", str(scene), "--plot", str(plot)]) == 0
    assert "a $\\foo$ engine" in report.read_text(encoding="utf-8")
    assert "$\\foo$" in plot.read_text(encoding="utf-8")
