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


# -- trace files (issue 32, item 1) ------------------------------------------------------------------

MEASURED = ROOT / "datasets" / "engines" / "tractor-3cyl-measured-gas.toml"
GOOD_TRACE = ROOT / "datasets" / "engines" / "traces" / "tractor-full-load.csv"


def _trace_scene(folder: Path, file: str) -> Path:
    """The measured-gas tractor in ``folder``, its trace read from ``file`` (as written in the scene)."""
    text = MEASURED.read_text(encoding="utf-8")
    written = 'file = "traces/tractor-full-load.csv"'
    assert text.count(written) == 1
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "engine.toml"
    scene.write_text(text.replace(written, f"file = {file!r}"), encoding="utf-8")
    return scene


def _trace_problem(scene: Path, **kwargs) -> str:
    with pytest.raises(hb.SceneError) as info:
        hb.load_scene(scene, **kwargs)
    (problem,) = info.value.problems
    assert problem.key == "gas.trace.file", str(problem)
    return problem.rule


@pytest.fixture(autouse=True)
def _no_trace_roots(monkeypatch):
    monkeypatch.delenv("HARMBAL_TRACE_ROOTS", raising=False)


def test_a_trace_in_the_scenes_folder_tree_is_read_and_kept(tmp_path):
    (tmp_path / "a" / "traces").mkdir(parents=True)
    shutil.copy(GOOD_TRACE, tmp_path / "a" / "traces" / "full.csv")
    scene = hb.load_scene(_trace_scene(tmp_path / "a", "traces/full.csv"))
    assert scene.files == (("traces/full.csv", GOOD_TRACE.read_text(encoding="utf-8")),)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_trace_is_refused_without_blocking(tmp_path, capsys):
    import signal

    os.mkfifo(tmp_path / "trace.csv")
    scene = _trace_scene(tmp_path, "trace.csv")
    previous = signal.signal(signal.SIGALRM, lambda *_: pytest.fail("reading the trace blocked"))
    signal.alarm(30)  # opening a FIFO for reading blocks until a writer comes: the alarm ends the test if it does
    try:
        assert main(["run", str(scene), "-o", str(tmp_path / "out.nc")]) == 2
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    line = _error(capsys)
    assert "gas.trace.file" in line and "not a regular file" in line
    assert not (tmp_path / "out.nc").exists()


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero here")
def test_dev_zero_is_refused_as_outside_and_as_a_device_when_allowed(tmp_path):
    scene = _trace_scene(tmp_path, "/dev/zero")
    assert "lies outside the scene's folder" in _trace_problem(scene)
    assert "not a regular file" in _trace_problem(scene, trace_roots=["/dev"])
    os.symlink("/dev/zero", tmp_path / "zero.csv")  # a link inside the folder to a device outside it
    assert "lies outside" in _trace_problem(_trace_scene(tmp_path, "zero.csv"))


def _outside_trace(tmp_path) -> tuple[Path, Path]:
    """A scene in tmp_path/scene and a good trace in tmp_path/elsewhere."""
    (tmp_path / "elsewhere").mkdir()
    trace = tmp_path / "elsewhere" / "trace.csv"
    shutil.copy(GOOD_TRACE, trace)
    return tmp_path / "scene", trace


def test_a_path_outside_the_scenes_folder_is_refused_saying_how_to_allow_it(tmp_path, monkeypatch):
    folder, trace = _outside_trace(tmp_path)
    (folder / "sub").mkdir(parents=True)
    for written in (str(trace), "../elsewhere/trace.csv", "sub/../../elsewhere/trace.csv"):
        rule = _trace_problem(_trace_scene(folder, written))
        assert "lies outside the scene's folder" in rule and "HARMBAL_TRACE_ROOTS" in rule and "trace_roots" in rule
    # allowed: by the keyword, or by the environment variable
    scene = _trace_scene(folder, "../elsewhere/trace.csv")
    assert hb.load_scene(scene, trace_roots=[trace.parent]).cylinders[0].gas is not None
    monkeypatch.setenv("HARMBAL_TRACE_ROOTS", os.pathsep.join(["/nowhere", str(trace.parent)]))
    assert hb.load_scene(scene).cylinders[0].gas is not None


def test_a_link_escaping_the_folder_is_refused_one_inside_is_read(tmp_path):
    folder, trace = _outside_trace(tmp_path)
    folder.mkdir()
    os.symlink(trace, folder / "escape.csv")
    assert "(which is" in _trace_problem(_trace_scene(folder, "escape.csv"))
    shutil.copy(GOOD_TRACE, folder / "real.csv")
    os.symlink(folder / "real.csv", folder / "link.csv")
    assert hb.load_scene(_trace_scene(folder, "link.csv")).cylinders[0].gas is not None


def test_a_file_that_is_no_trace_is_refused_without_echoing_it(tmp_path, capsys):
    secret = "root:x:0:0:SECRET-VALUE-1234:/root:/bin/bash\ndaemon:x:1:1:ANOTHER-SECRET:/usr/sbin\n"
    (tmp_path / "passwd.csv").write_text(secret, encoding="utf-8")
    scene = _trace_scene(tmp_path, "passwd.csv")
    assert main(["run", str(scene)]) == 2
    line = _error(capsys)
    assert "gas.trace.file" in line and "line 2" in line and "is this a pressure trace?" in line
    assert "SECRET" not in line and "x:0:0" not in line and "daemon" not in line
    if Path("/etc/passwd").exists():  # the case: refused as outside the folder, never opened
        assert "lies outside" in _trace_problem(_trace_scene(tmp_path, "/etc/passwd"))


def test_a_bad_token_in_a_trace_is_shown_shortened(tmp_path):
    text = GOOD_TRACE.read_text(encoding="utf-8")
    lines = text.splitlines()
    lines[20] = "12.5," + "x" * 100
    (tmp_path / "trace.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    rule = _trace_problem(_trace_scene(tmp_path, "trace.csv"))
    assert "line 21" in rule and "'" + "x" * 20 + "…'" in rule and "x" * 21 not in rule


@pytest.mark.parametrize("content, rule", [(b"\xff\xfe" + "angle".encode("utf-16-le"), "save it as UTF-8"),
                                           (None, "larger than 16 MiB")])
def test_oversized_or_undecodable_traces_are_refused(tmp_path, content, rule):
    path = tmp_path / "trace.csv"
    if content is None:
        with path.open("wb") as file:
            file.truncate((16 << 20) + 1)  # sparse: nothing is written, and nothing need be read
    else:
        path.write_bytes(content)
    assert rule in _trace_problem(_trace_scene(tmp_path, "trace.csv"))


# -- the scene stored in an archive is re-read without the file system (item 2) --------------------

def test_a_report_of_an_archive_moved_away_from_its_deleted_trace(tmp_path, monkeypatch, capsys):
    (tmp_path / "a" / "traces").mkdir(parents=True)
    shutil.copy(GOOD_TRACE, tmp_path / "a" / "traces" / "full.csv")
    _trace_scene(tmp_path / "a", "traces/full.csv")
    monkeypatch.chdir(tmp_path / "a")
    assert main(["run", "engine.toml", "-o", "out.nc"]) == 0
    (tmp_path / "b").mkdir()
    shutil.move(tmp_path / "a" / "out.nc", tmp_path / "b" / "out.nc")
    shutil.rmtree(tmp_path / "a" / "traces")
    monkeypatch.chdir(tmp_path / "b")
    capsys.readouterr()
    assert main(["report", "out.nc", "-o", "report.html"]) == 0, capsys.readouterr().err
    assert "tractor" in (tmp_path / "b" / "report.html").read_text(encoding="utf-8")


def test_given_files_are_the_only_files_read(tmp_path):
    from harmbal.scene import scene_from_text

    text = MEASURED.read_text(encoding="utf-8")
    files = {"traces/tractor-full-load.csv": GOOD_TRACE.read_text(encoding="utf-8")}
    nowhere = str(tmp_path / "no-such-folder" / "engine.toml")
    read, from_disk = scene_from_text(text, nowhere, files=files).cylinders[0], hb.load_scene(MEASURED).cylinders[0]
    assert read.gas.trace.pressure == from_disk.gas.trace.pressure and read.gas.trace.angle == from_disk.gas.trace.angle
    tampered = text.replace('"traces/tractor-full-load.csv"', '"/dev/zero"')
    with pytest.raises(hb.SceneError, match=r"gas\.trace\.file = '/dev/zero': not among the trace files stored"):
        scene_from_text(tampered, nowhere, files=files)


def test_a_tampered_or_old_archive_scene(tmp_path):
    from harmbal.reporting.html import _stored_scene

    scene = hb.load_scene(MEASURED)
    attrs = hb.analyse(scene)["scene"].ds.attrs
    tampered = dict(attrs, scene_toml=attrs["scene_toml"].replace('"traces/tractor-full-load.csv"', '"/dev/zero"'))
    with pytest.raises(hb.SceneError, match="not among the trace files stored"):
        _stored_scene(tampered)  # never opens /dev/zero
    with pytest.raises(hb.SceneError, match="damaged"):
        _stored_scene(dict(attrs, scene_files="[1, 2]"))
    old = {k: v for k, v in attrs.items() if k != "scene_files"}  # before traces were stored: from the disk
    assert _stored_scene(old).cylinders[0].gas == scene.cylinders[0].gas
    with pytest.raises(hb.SceneError, match="file not found"):
        _stored_scene(dict(old, source=str(tmp_path / "engine.toml")))
