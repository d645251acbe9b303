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
