"""Archives under faults (issue 32): damage is an ArchiveError, never changed numbers or another exception;
nothing outside the file is read; a killed, failed or concurrent write loses no file and leaves nothing
behind; a full disk is one line.

Oracles: the tree as written (``xr.testing.assert_identical``); the bytes of the file before damage;
the file system itself (what is left in the folder); real kills, real full disks (a small tmpfs).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import harmbal as hb
from harmbal.io import archive, files
from harmbal.io.files import WriteError, clean_orphans
from harmbal.io.integrity import CHECKSUM_ATTR, TRAILER_SIZE

ROOT = Path(__file__).resolve().parent.parent
INLINE4 = ROOT / "datasets" / "engines" / "inline-4.toml"
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}


@pytest.fixture(scope="module")
def tree():
    return hb.analyse(hb.load_scene(INLINE4))


@pytest.fixture(scope="module")
def written(tree, tmp_path_factory):
    path = tmp_path_factory.mktemp("written") / "inline-4.nc"
    hb.save(tree, path)
    return path


def _assert_same(got, want):
    assert sorted(n.path for n in got.subtree) == sorted(n.path for n in want.subtree)
    assert got.attrs == want.attrs
    for node in want.subtree:
        xr.testing.assert_identical(got[node.path].to_dataset(inherit=False), node.to_dataset(inherit=False))


def _refused(path, match: str | None = None) -> str:
    """Open ``path`` expecting an ArchiveError of one line that names the file; return its text."""
    with pytest.raises(hb.ArchiveError) as info:
        hb.open_archive(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(path)), text
    if match is not None:
        assert match in text, text
    return text


def _without_trailer(source: Path, target: Path) -> Path:
    """A copy whose whole-file checksum is gone (as if a tool had rewritten the file): only the checksums
    inside the file remain."""
    data = source.read_bytes()
    assert data[-TRAILER_SIZE:].startswith(b"\nharmbal archive sha256 ")
    target.write_bytes(data[:-TRAILER_SIZE])
    return target


# --- damage -------------------------------------------------------------------------------------------------


def test_corruption_campaign(tree, written, tmp_path):
    """~100 bytes changed at seeded places over the whole file, and truncations: each copy opens to the tree
    as written (a byte past what HDF5 reads) or is an ArchiveError, never another exception or other values."""
    data = written.read_bytes()
    rng = np.random.default_rng(32)
    positions = np.sort(rng.choice(len(data), 100, replace=False))
    cases = [("flip", int(p)) for p in positions]
    cases += [("truncate", n) for n in (0, 8, 100, 512, len(data) // 3, len(data) // 2, len(data) - TRAILER_SIZE - 1,
                                         len(data) - 1)]
    outcomes = {"same": 0, "refused": 0}
    copy = tmp_path / "damaged.nc"
    for kind, where in cases:
        damaged = bytearray(data)
        if kind == "flip":
            damaged[where] ^= 1 << int(rng.integers(8))
        else:
            damaged = damaged[:where]
        copy.write_bytes(bytes(damaged))
        try:
            got = hb.open_archive(copy)
        except hb.ArchiveError as exc:
            assert "\n" not in str(exc) and str(exc).startswith(str(copy)), (kind, where, exc)
            outcomes["refused"] += 1
        else:
            _assert_same(got, tree)
            outcomes["same"] += 1
    assert outcomes["refused"] >= 100  # the trailer covers every byte HDF5 reads: only the trailer's own are free


def test_data_damage_without_the_trailer_names_the_variable(tree, written, tmp_path):
    """With the whole-file checksum gone, HDF5's fletcher32 still checks every chunk it reads."""
    import h5py

    plain = _without_trailer(written, tmp_path / "plain.nc")
    _assert_same(hb.open_archive(plain), tree)  # still verified by what is inside the file
    with h5py.File(plain, "r") as f:
        chunks = {name: f[name].id.get_chunk_info(0) for name in ("orders/force", "time/moment", "stars/star_angle")}
        assert all(f[name].fletcher32 for name in chunks)
    data = plain.read_bytes()
    rng = np.random.default_rng(7)
    for name, chunk in chunks.items():
        for offset in rng.integers(0, chunk.size, 5):
            damaged = bytearray(data)
            damaged[chunk.byte_offset + int(offset)] ^= 0x10
            copy = tmp_path / "chunk.nc"
            copy.write_bytes(bytes(damaged))
            group, variable = name.split("/")
            _refused(copy, f"group /{group}, variable {variable}: data checksum mismatch")


def test_altered_values_and_attributes_are_named(written, tmp_path):
    """A valid HDF5 edit (HDF5 recomputes its own checksums) still fails harmbal's digests."""
    import h5py

    cases = {
        "data": (lambda f: f["orders/force"].__setitem__((0, 1, 0, 0), 1.0),
                 "group /orders, variable force: data checksum mismatch"),
        "string data": (lambda f: f["stars/firing_sequence"].__setitem__(0, "4"),
                        "group /stars, variable firing_sequence: data checksum mismatch"),
        "variable attribute": (lambda f: f["orders/moment"].attrs.__setitem__("units", "kN m"),
                               "group /orders, variable moment: metadata"),
        "group attribute": (lambda f: f["scene"].attrs.__setitem__("scene_toml", "[engine]\n"),
                            "group /scene: attributes changed since written"),
        "deleted checksum": (lambda f: f.attrs.__delitem__(CHECKSUM_ATTR), f"the {CHECKSUM_ATTR} attribute is missing"),
        "damaged checksum": (lambda f: f.attrs.__setitem__(CHECKSUM_ATTR, "{not json"), "attribute is damaged"),
    }
    for label, (edit, message) in cases.items():
        copy = _without_trailer(written, tmp_path / f"{label.replace(' ', '-')}.nc")
        with h5py.File(copy, "r+") as f:
            edit(f)
        _refused(copy, message)
        # the same edit with the trailer kept: the whole-file checksum sees it first
        whole = tmp_path / "whole.nc"
        whole.write_bytes(written.read_bytes())
        with h5py.File(whole, "r+") as f:
            edit(f)
        _refused(whole)


def _plain_netcdf(path: Path, groups: dict, root_attrs: dict | None = None) -> Path:
    """A netCDF file written by plain xarray (no checksums: read like an archive of an earlier harmbal)."""
    xr.DataTree.from_dict({"/": xr.Dataset(attrs=root_attrs or {}), **groups}).to_netcdf(path, engine="h5netcdf")
    return path


def test_structure_problems_of_unverified_archives_are_archive_errors(tmp_path):
    speeds = {"speed": ("speed", [100.0, 200.0]), "rpm": ("speed", [955.0, 1910.0])}
    cases = {
        "complex_encoding without a 'part' dimension of 2": {"/orders": xr.Dataset({"force": (
            ("order",), [1.0, 2.0], {"complex_encoding": archive._ENCODING})})},
        "no speed coordinate": {"/orders": xr.Dataset({"force_per_speed_squared": (
            ("order",), [1.0, 2.0], {"per_speed_name": "force", "per_speed_units": "N"})})},
        "no per_speed_units attribute": {"/orders": xr.Dataset({"force_per_speed_squared": (
            ("order",), [1.0, 2.0], {"per_speed_name": "force"})}, coords=speeds)},
    }
    for message, groups in cases.items():
        _refused(_plain_netcdf(tmp_path / "bad.nc", groups), message)
    absent = _plain_netcdf(tmp_path / "absent.nc", {"/orders": xr.Dataset({"x": ("order", [1.0])})},
                           {"speed_coordinates_of": "/orders /loads"})
    _refused(absent, "speed_coordinates_of names")
    # an earlier archive is still read (unverified): a legacy fixture
    legacy = sorted((ROOT / "tests" / "fixtures" / "legacy").glob("*.nc"))[0]
    assert "orders" in hb.open_archive(legacy).children


def test_not_an_archive(tmp_path):
    (tmp_path / "dir.nc").mkdir()
    _refused(tmp_path / "dir.nc")
    (tmp_path / "text.nc").write_text("[engine]\n", encoding="utf-8")
    _refused(tmp_path / "text.nc")
    (tmp_path / "file.zarr").write_text("{}", encoding="utf-8")
    _refused(tmp_path / "file.zarr")
    with pytest.raises(FileNotFoundError):
        hb.open_archive(tmp_path / "missing.nc")


@pytest.mark.parametrize("command", ["show", "report"])
def test_cli_on_a_damaged_archive_is_one_line(written, tmp_path, command):
    damaged = bytearray(written.read_bytes())
    damaged[len(damaged) // 2] ^= 0x04
    path = tmp_path / "damaged.nc"
    path.write_bytes(bytes(damaged))
    args = [str(path)] + (["-o", str(tmp_path / "r.html")] if command == "report" else [])
    done = subprocess.run([sys.executable, "-m", "harmbal", command, *args], capture_output=True, text=True, env=ENV,
                          cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"harmbal: error: {path}: "), lines
    assert not (tmp_path / "r.html").exists()


# --- nothing but the file itself ------------------------------------------------------------------------------


SECRET = b"the bytes of some other file\n" * 4


def test_external_storage_links_and_virtual_data_are_refused(tmp_path):
    import h5py

    secret = tmp_path / "secret.bin"
    secret.write_bytes(SECRET)
    crafted = {
        "external storage": lambda f: f.create_dataset("data/x", shape=(len(SECRET),), dtype="u1",
                                                       external=[(str(secret), 0, len(SECRET))]),
        "external link": lambda f: f.__setitem__("data/x", h5py.ExternalLink(str(tmp_path / "other.nc"), "/x")),
        "soft link": lambda f: (f.create_dataset("data/y", data=np.arange(3.0)),
                                f.__setitem__("data/x", h5py.SoftLink("/data/y"))),
        "virtual dataset": lambda f: f.create_virtual_dataset("data/x", _virtual_layout(tmp_path)),
        "plugin filter": lambda f: f.create_dataset("data/x", shape=(4,), dtype="f8", chunks=(4,), compression=32013,
                                                    allow_unknown_filter=True),
        "memory bomb": lambda f: f.create_dataset("data/x", shape=(1 << 40,), dtype="f8", chunks=(1 << 16,)),
    }
    for label, make in crafted.items():
        path = tmp_path / f"{label.replace(' ', '-')}.nc"
        with h5py.File(path, "w") as f:
            make(f)
        text = _refused(path)
        assert "some other file" not in text, label
    # what a plain reader would have returned: the other file's bytes
    with h5py.File(tmp_path / "external-storage.nc", "r") as f:
        assert f["data/x"][:].tobytes() == SECRET


def _virtual_layout(tmp_path):
    import h5py

    with h5py.File(tmp_path / "source.h5", "w") as f:
        f["x"] = np.frombuffer(SECRET, dtype="u1")
    layout = h5py.VirtualLayout(shape=(len(SECRET),), dtype="u1")
    layout[:] = h5py.VirtualSource(str(tmp_path / "source.h5"), "x", shape=(len(SECRET),))
    return layout


# --- Zarr ------------------------------------------------------------------------------------------------------


@pytest.fixture
def store(tree, tmp_path):
    pytest.importorskip("zarr")
    return hb.save(tree, tmp_path / "inline-4.zarr")


def _chunk(store: Path, array: str) -> Path:
    return sorted(p for p in (store / array).iterdir() if not p.name.startswith("."))[0]


def test_zarr_damage(tree, store, tmp_path):
    _assert_same(hb.open_archive(store), tree)
    cases = {"flipped chunk": lambda s: _flip(_chunk(s, "orders/force")),
             "missing chunk": lambda s: _chunk(s, "time/moment").unlink(),
             "altered attribute": lambda s: _replace_text(s, '"units": "N m"', '"units": "kN m"'),
             "symbolic link": lambda s: _symlink_chunk(s, tmp_path)}
    for label, damage in cases.items():
        copy = tmp_path / f"{label.replace(' ', '-')}.zarr"
        shutil.copytree(store, copy, symlinks=True)
        damage(copy)
        text = _refused(copy)
        assert "some other file" not in text, label


def _flip(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))


def _replace_text(store: Path, old: str, new: str) -> None:
    for meta in [store / ".zmetadata", *store.glob("*/*/.zattrs")]:
        text = meta.read_text(encoding="utf-8").replace(old.replace(" ", ""), new.replace(" ", "")).replace(old, new)
        meta.write_text(text, encoding="utf-8")


def _symlink_chunk(store: Path, tmp_path: Path) -> None:
    (tmp_path / "secret.bin").write_bytes(SECRET)
    chunk = _chunk(store, "orders/force")
    chunk.unlink()
    chunk.symlink_to(tmp_path / "secret.bin")


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_zarr_replacement_keeps_a_store_at_every_moment(tree, store, tmp_path, monkeypatch):
    single = hb.analyse(hb.load_scene(ROOT / "datasets" / "engines" / "single.toml"))
    swaps, exchange = [], files._exchange
    monkeypatch.setattr(files, "_exchange", lambda a, b: swaps.append(exchange(a, b)) or swaps[-1])
    hb.save(single, store)  # replaced by an atomic exchange of names where the system has one
    assert swaps == [True] or not sys.platform.startswith("linux")
    _assert_same(hb.open_archive(store), single)
    assert sorted(p.name for p in tmp_path.iterdir()) == [store.name]
    monkeypatch.setattr(files, "_exchange", lambda a, b: False)  # a system without renameat2: two renames
    hb.save(tree, store)
    _assert_same(hb.open_archive(store), tree)
    assert sorted(p.name for p in tmp_path.iterdir()) == [store.name]


def test_a_store_lost_between_two_renames_is_put_back(tree, store, tmp_path):
    """A writer killed between its two renames leaves the old store in .NAME.<pid>-<host>.<random>.old/NAME and
    its new one in a .tmp: reading or writing that path puts the old store back and removes the rest."""
    for action in ("open", "write"):
        dead = _dead_pid()
        old = tmp_path / f".{store.name}.{dead}-{files._host()}.abc123.old"
        old.mkdir()
        store.rename(old / store.name)
        half = tmp_path / f".{store.name}.{dead}-{files._host()}.def456.tmp"
        half.mkdir()
        (half / ".zgroup").write_text("{", encoding="utf-8")
        assert not store.exists()
        if action == "open":
            _assert_same(hb.open_archive(store), tree)
            clean_orphans(store)
        else:
            hb.save(tree, store)
        assert sorted(p.name for p in tmp_path.iterdir()) == [store.name]
        _assert_same(hb.open_archive(store), tree)


# --- temporaries, kills, concurrent writers -----------------------------------------------------------------------


def test_orphaned_temporaries_of_the_target_are_cleaned_and_nothing_else(tree, tmp_path):
    host, dead, alive = files._host(), _dead_pid(), os.getpid()
    other_host = "0" * 8 if host != "0" * 8 else "1" * 8
    orphans = [f".x.nc.{dead}-{host}.k2j4x8_q.tmp", f".x.nc.{dead}-{host}.aaaa1111.old"]
    kept = [f".x.nc.{alive}-{host}.abcd1234.tmp",  # a running writer (this process)
            f".x.nc.{dead}-{other_host}.abcd1234.tmp",  # a writer on another machine sharing the folder
            ".x.nc.abcd1234.tmp",  # the pattern of earlier versions: no owner to ask
            f".y.nc.{dead}-{host}.abcd1234.tmp",  # another target
            f"x.nc.{dead}-{host}.abcd1234.tmp", f".x.nc.{dead}-{host}.abcd1234.tmp.keep", "notes.txt"]
    for name in orphans + kept:
        (tmp_path / name).write_bytes(b"x")
    (tmp_path / orphans[1]).unlink()
    (tmp_path / orphans[1]).mkdir()  # an .old folder
    hb.save(tree, tmp_path / "x.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept + ["x.nc"])


KILLED_WRITER = """
import os, sys, time
import dask.array as da, numpy as np, xarray as xr
import harmbal as hb

target, marker = sys.argv[1], sys.argv[2]

def slow(block):
    if not os.path.exists(marker):
        open(marker, "w").close()
    while True:  # the write hangs here until the test kills the process
        time.sleep(0.05)

data = da.map_blocks(slow, da.zeros((64, 1024), chunks=(8, 1024)), dtype=float, meta=np.array((), dtype=float))
tree = xr.DataTree.from_dict({"/": xr.Dataset(), "/big": xr.Dataset({"x": (("a", "b"), data)})})
hb.save(tree, target)
"""


@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_kill_9_mid_write(tree, tmp_path, suffix):
    """A real SIGKILL while the values are written: the file already at the target is untouched, the killed
    writer's temporary is left, and the next write removes it."""
    if suffix == ".zarr":
        pytest.importorskip("zarr")
    pytest.importorskip("dask")
    target, marker = tmp_path / f"out{suffix}", tmp_path / "writing"
    hb.save(tree, target)
    before = hb.open_archive(target)
    script = tmp_path / "writer.py"
    script.write_text(KILLED_WRITER, encoding="utf-8")
    child = subprocess.Popen([sys.executable, str(script), str(target), str(marker)], env=ENV)
    try:
        for _ in range(1200):  # until the writer is inside the write (at most 2 min)
            if marker.exists() or child.poll() is not None:
                break
            try:
                child.wait(timeout=0.1)
            except subprocess.TimeoutExpired:
                pass
        assert marker.exists(), "the writer never started writing"
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
    marker.unlink()
    left = sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(f".{target.name}."))
    assert len(left) == 1 and left[0].startswith(f".{target.name}.{child.pid}-") and left[0].endswith(".tmp")
    _assert_same(hb.open_archive(target), before)
    hb.save(tree, target)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([target.name, "writer.py"])


CONCURRENT_WRITER = """
import sys
import harmbal as hb

tree = hb.analyse(hb.load_scene(sys.argv[2]))
for _ in range(5):
    hb.save(tree, sys.argv[1])
"""


def test_two_writers_to_one_path_leave_one_valid_archive(tree, tmp_path):
    target = tmp_path / "both.nc"
    script = tmp_path / "writer.py"
    script.write_text(CONCURRENT_WRITER, encoding="utf-8")
    other = ROOT / "datasets" / "engines" / "single.toml"
    writers = [subprocess.Popen([sys.executable, str(script), str(target), str(scene)], env=ENV)
               for scene in (INLINE4, other)]
    assert [w.wait() for w in writers] == [0, 0]
    got = hb.open_archive(target)
    assert got.attrs["engine"] in ("inline-4", "single")
    _assert_same(got, tree if got.attrs["engine"] == "inline-4" else hb.analyse(hb.load_scene(other)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["both.nc", "writer.py"]


# --- full disk ---------------------------------------------------------------------------------------------------


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs (skipped where mounting is not allowed), always unmounted."""
    if not sys.platform.startswith("linux") or os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a small tmpfs needs root on Linux")
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)], capture_output=True,
                          text=True)
    if done.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


def test_full_disk_is_refused_before_writing(tree, small_disk):
    with pytest.raises(WriteError) as info:
        hb.save(hb.analyse(hb.load_scene(ROOT / "datasets" / "engines" / "v8-cross-plane-gas.toml")),
                small_disk / "x.nc")
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"{small_disk / 'x.nc'}: no space left on device"), text
    assert isinstance(info.value, OSError) and info.value.errno == 28
    assert list(small_disk.iterdir()) == []
    hb.save(tree, small_disk / "fits.nc")  # a smaller archive still fits, and is complete
    _assert_same(hb.open_archive(small_disk / "fits.nc"), tree)


def test_full_disk_while_writing_a_store(tree, small_disk):
    pytest.importorskip("zarr")
    (small_disk / "ballast").write_bytes(b"\0" * (960 << 10))  # leave less than the store needs (no reservation)
    with pytest.raises(WriteError, match="no space left on device"):
        hb.save(tree, small_disk / "x.zarr")
    assert sorted(p.name for p in small_disk.iterdir()) == ["ballast"]


@pytest.mark.parametrize("command", [
    ["run", str(INLINE4), "-o", "{disk}/x.nc"],
    ["sweep", str(INLINE4), "--set", "piston.mass=0.3:0.5:2000", "-o", "{disk}/x.nc"],
    ["report", str(INLINE4), "-o", "{disk}/x.html"],
])
def test_cli_on_a_full_disk_is_one_line(small_disk, command):
    (small_disk / "ballast").write_bytes(b"\0" * (1016 << 10))
    args = [arg.format(disk=small_disk) for arg in command]
    done = subprocess.run([sys.executable, "-m", "harmbal", *args], capture_output=True, text=True, env=ENV)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("harmbal: error:")]
    assert len(lines) == 1 and "no space left on device" in lines[0], done.stderr
    assert sorted(p.name for p in small_disk.iterdir()) == ["ballast"]


def test_the_size_estimate_is_an_upper_bound(tmp_path, monkeypatch):
    """The reservation must hold the whole file: HDF5 does not survive running out of space."""
    estimates = []
    real = archive.netcdf_size
    monkeypatch.setattr(archive, "netcdf_size", lambda nodes: estimates.append(real(nodes)) or estimates[-1])
    v8 = hb.load_scene(ROOT / "datasets" / "engines" / "v8-cross-plane.toml")
    trees = [hb.analyse(hb.load_scene(ROOT / "datasets" / "engines" / f"{stem}.toml"), per_cylinder=True)
             for stem in ("inline-4", "v8-cross-plane-gas", "tractor-3cyl-loads-gas", "w24-broad-arrow")]
    trees += [hb.analyse(v8.with_speeds(np.linspace(60.0, 800.0, n))) for n in (5000, 200_000)]
    for i, t in enumerate(trees):
        path = hb.save(t, tmp_path / f"{i}.nc")
        assert os.path.getsize(path) - TRAILER_SIZE <= estimates[-1], i
