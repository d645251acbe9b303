"""The HTML report (harmbal.report, `harmbal report`).

Oracles: the datasets the report is made from (numbers parsed back out of the
page's tables and compared with hb.analyse's Datasets), the report of the
same scene made through an archive (byte-identical), and the HTML itself
parsed with the standard library (self-contained: no external resources;
every figure an inline SVG of non-zero size).
"""

from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"


class _Page(HTMLParser):
    """Tables (rows of cell texts, per section id), figures and every URL-like attribute."""

    def __init__(self):
        super().__init__()
        self.section = None
        self.tables: dict[str, list[list[list[str]]]] = {}
        self.figures: list[tuple[str, dict]] = []
        self.urls: list[str] = []
        self.tags: set[str] = set()
        self._cell = None
        self._figure = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.add(tag)
        for key in ("src", "href", "xlink:href"):
            if key in attrs:
                self.urls.append(attrs[key])
        if tag == "section":
            self.section = attrs.get("id")
        elif tag == "table":
            self.tables.setdefault(self.section, []).append([])
        elif tag == "tr":
            self.tables[self.section][-1].append([])
        elif tag in ("td", "th"):
            self._cell = ""
        elif tag == "figure":
            self._figure = attrs.get("data-figure")
        elif tag == "svg" and self._figure is not None:
            self.figures.append((self._figure, attrs))
            self._figure = None

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[self.section][-1][-1].append(self._cell)
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def _parse(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    return page


@pytest.fixture(scope="module")
def lever_tree():
    return hb.analyse(hb.load_scene(ENGINES / "lever-single.toml"))


@pytest.fixture(scope="module")
def balanced_tree():
    return hb.analyse(hb.load_scene(ENGINES / "inline-3-balanced.toml"))


@pytest.fixture(scope="module")
def lever_html(lever_tree):
    return hb.report(lever_tree)


@pytest.fixture(scope="module")
def balanced_html(balanced_tree):
    return hb.report(balanced_tree)


def _value(cell: str) -> float:
    return 0.0 if cell.strip() == "0" else float(cell.split()[0])


@pytest.mark.parametrize("which", ["lever", "balanced"])
def test_report_from_an_archive_equals_the_report_from_its_scene(tmp_path, which, lever_tree, balanced_tree,
                                                                 lever_html, balanced_html):
    tree, direct = (lever_tree, lever_html) if which == "lever" else (balanced_tree, balanced_html)
    hb.save(tree, tmp_path / "a.nc")
    assert hb.report(hb.open_archive(tmp_path / "a.nc")) == direct


def test_self_contained_and_every_figure_inline(balanced_html, lever_html):
    for text, expected in ((balanced_html, {"spectrum", "stars", "traces", "locus", "phasing"}),
                           (lever_html, {"spectrum", "stars", "traces", "locus", "mechanism", "lever"})):
        page = _parse(text)
        assert not ({"script", "link", "img", "iframe", "object"} & page.tags)
        assert all(not url.startswith(("http:", "https:", "//", "data:")) for url in page.urls), page.urls
        assert {name for name, _ in page.figures} == expected
        for name, attrs in page.figures:
            width, height = (float(attrs[k].rstrip("pt")) for k in ("width", "height"))
            assert width > 0 and height > 0, name
        assert "@media print" in text and "break-inside: avoid" in text


def test_summary_names_the_model_and_sampling(lever_tree, lever_html):
    rows = {r[0]: r[1] for r in _parse(lever_html).tables["settings"][0][1:]}
    time = lever_tree["time"].ds
    assert rows["engine"] == "lever-single"
    assert rows["effects simulated"] == time.attrs["effects"]
    assert rows["sampling"].startswith(f"{time.attrs['samples_per_rev']} samples per revolution")
    assert rows["harmbal version"] == hb.__version__


def test_order_tables_equal_the_orders_dataset(balanced_tree, balanced_html):
    orders = balanced_tree["orders"].ds
    tables = _parse(balanced_html).tables["spectrum"]
    for table, name in zip(tables, ("force", "moment")):
        values = np.abs(orders[name].values)
        rotating = np.abs(orders[f"{name}_rotating"].values)
        scale = float(orders[f"{name}_scale"])
        for row in table[1:]:
            k = int(row[0])
            expected = list(values[k]) + list(rotating[k])
            level = float(orders[f"{name}_negligible_level"])
            for cell, want in zip(row[1::2], expected):
                if cell == "0":
                    assert want <= orders.attrs["zero_rtol"] * scale
                elif cell == "~0":
                    assert orders.attrs["zero_rtol"] * scale < want <= level
                else:
                    assert _value(cell) == pytest.approx(want, rel=1e-4) and want > level


def test_verification_and_joint_tables_equal_their_datasets(balanced_tree, lever_tree, balanced_html, lever_html):
    check = balanced_tree["verify"].ds
    table = _parse(balanced_html).tables["balancers"][-1]
    assert len(table) - 1 == int(check["targeted"].sum()) * check.sizes["order"]
    assert all(row[-1] == "pass" for row in table[1:])
    joints = lever_tree["joints"].ds
    rows = _parse(lever_html).tables["lever"][0][1:]
    assert [r[0] for r in rows] == list(joints["joint"].values)
    for row, peak in zip(rows, joints["joint_force_peak"].values):
        assert _value(row[2]) == pytest.approx(peak, rel=1e-4)


def test_balancer_table_lists_every_unbalance(balanced_html):
    scene = hb.load_scene(ENGINES / "inline-3-balanced.toml")
    rows = _parse(balanced_html).tables["balancers"][0][1:]
    expected = [(s.label, u.unbalance * 1e3) for s in scene.shafts for u in s.unbalances]
    assert [(r[0], _value(r[3])) for r in rows] == [(label, pytest.approx(u, rel=1e-4)) for label, u in expected]


def test_log_option_changes_only_the_spectrum(balanced_tree, balanced_html):
    linear, log = balanced_html, hb.report(balanced_tree, log=True)
    assert linear != log
    assert linear.split('id="stars"')[1] == log.split('id="stars"')[1]


def test_cli_report(tmp_path, capsys):
    out = tmp_path / "r.html"
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    archive = tmp_path / "a.nc"
    assert main(["run", str(ENGINES / "v-twin-90.toml"), "-o", str(archive)]) == 0
    again = tmp_path / "again.html"
    assert main(["report", str(archive), "-o", str(again)]) == 0
    assert again.read_text(encoding="utf-8") == out.read_text(encoding="utf-8")


@pytest.mark.parametrize("output", ["r.txt", "missing/r.html"])
def test_cli_report_bad_output_exits_2_and_writes_nothing(tmp_path, capsys, output):
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(tmp_path / output)]) == 2
    assert "harmbal: error:" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_cli_report_css_is_added_after_the_built_in_style(tmp_path):
    css = tmp_path / "house.css"
    css.write_text("body { font-family: 'House Sans'; }\n", encoding="utf-8")
    out = tmp_path / "r.html"
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(out), "--css", str(css)]) == 0
    style = out.read_text(encoding="utf-8").split("<style>")[1].split("</style>")[0]
    assert style.endswith("body { font-family: 'House Sans'; }\n")
    assert style.index("system-ui") < style.index("House Sans")


@pytest.mark.parametrize("content", [None, "</style><script>alert(1)</script>"])
def test_cli_report_bad_css_exits_2_and_writes_nothing(tmp_path, capsys, content):
    css = tmp_path / "house.css"
    if content is not None:
        css.write_text(content, encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(out / "r.html"), "--css", str(css)]) == 2
    assert "house.css" in capsys.readouterr().err
    assert list(out.iterdir()) == []


def test_a_speed_sweep_gets_campbell_maps_whose_colours_are_its_order_amplitudes():
    from harmbal.reporting.sweep_plots import campbell_figure
    from harmbal.studies.sweep import order_amplitude

    scene = hb.load_scene(ENGINES / "v-twin-90.toml")
    swept = hb.analyse(scene.with_speeds(np.linspace(200.0, 900.0, 8)))
    names = {name for name, _ in _parse(hb.report(swept)).figures}
    assert {"campbell-force", "campbell-moment"} <= names
    two = hb.analyse(scene.with_speeds([300.0, 600.0]))
    assert not {n for n, _ in _parse(hb.report(two)).figures} & {"campbell-force", "campbell-moment"}
    # The map's cells are the order amplitudes per (speed, order), floored at 1e-6 of the largest.
    orders = swept["orders"].ds
    mesh = campbell_figure(orders, name="moment").axes[0].collections[0]
    amplitude = order_amplitude(orders["moment"].transpose("speed", "order", "axis").values)
    expected = np.maximum(amplitude, amplitude.max() * 1e-6).T
    np.testing.assert_allclose(np.asarray(mesh.get_array()).reshape(expected.shape), expected, rtol=1e-15)


def _provenance(text: str) -> str:
    return text[text.index('<section id="provenance">'):text.index("<h3>Scene</h3>")]


def _fake_checkout(root: Path, head: str, refs: dict[str, str] | None = None, packed: str = "") -> Path:
    """A folder ``root`` with the .git files git writes: HEAD, ref files, packed-refs."""
    git = root / ".git"
    git.mkdir(parents=True)
    (root / "pyproject.toml").write_text('[project]\nname = "harmbal"\n')
    (git / "HEAD").write_text(head + "\n")
    for ref, name in (refs or {}).items():
        (git / ref).parent.mkdir(parents=True, exist_ok=True)
        (git / ref).write_text(name + "\n")
    if packed:
        (git / "packed-refs").write_text(packed)
    return root


COMMIT = "0123456789abcdef0123456789abcdef01234567"


def test_source_revision_reads_a_checkout_without_git(tmp_path):
    """Oracle: the layouts git writes (HEAD naming a branch whose ref is a file or a line of packed-refs, a
    detached HEAD, a worktree's .git file); anything else is "unknown", never an error."""
    from harmbal._version import UNKNOWN_REVISION, source_revision

    branch = _fake_checkout(tmp_path / "branch", "ref: refs/heads/main", {"refs/heads/main": COMMIT})
    packed = _fake_checkout(tmp_path / "packed", "ref: refs/heads/main",
                            packed=f"# pack-refs with: peeled fully-peeled sorted\n{'f' * 40} refs/heads/other\n"
                                   f"{COMMIT} refs/heads/main\n")
    detached = _fake_checkout(tmp_path / "detached", COMMIT)
    worktree = tmp_path / "worktree"
    worktree.mkdir()
    (worktree / "pyproject.toml").write_text('[project]\nname = "harmbal"\n')
    linked = branch / ".git" / "worktrees" / "wt"
    linked.mkdir(parents=True)
    (linked / "HEAD").write_text("ref: refs/heads/main\n")
    (linked / "commondir").write_text("../..\n")
    (worktree / ".git").write_text(f"gitdir: {linked}\n")
    for root in (branch, packed, detached, worktree):
        assert source_revision(root) == COMMIT, root
    broken = _fake_checkout(tmp_path / "broken", "ref: refs/heads/gone")
    junk = _fake_checkout(tmp_path / "junk", "not a commit")
    other = _fake_checkout(tmp_path / "other", COMMIT)
    (other / "pyproject.toml").write_text('[project]\nname = "not-harmbal"\n')  # a project holding a copy
    wheel = tmp_path / "wheel"  # harmbal's files without a .git folder
    wheel.mkdir()
    (wheel / "pyproject.toml").write_text('[project]\nname = "harmbal"\n')
    for root in (tmp_path / "none", wheel, broken, junk, other):
        assert source_revision(root) == UNKNOWN_REVISION, root


def test_source_revision_is_the_commit_git_reports():
    import shutil
    import subprocess

    from harmbal._version import source_revision

    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs git and a git checkout of harmbal")
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True)
    if head.returncode != 0:
        pytest.skip(head.stderr)
    assert source_revision() == head.stdout.strip()


def test_provenance_says_how_to_reproduce_with_what_exists(balanced_tree, balanced_html):
    """No install from a package index (harmbal is on none): the version, the source revision of the analysis
    with the commands to check it out and install it, and the report's command line."""
    from harmbal._version import source_revision

    scene = hb.load_scene(ENGINES / "inline-3-balanced.toml")
    text = _provenance(balanced_html)
    assert "pip install harmbal==" not in text
    revision = balanced_tree.attrs["source_revision"]
    assert revision == source_revision()
    assert f"harmbal {hb.__version__}" in text
    command = f"harmbal report {scene.source} -o report.html"
    if revision == "unknown":
        assert "source revision unknown" in text and "<pre>git checkout" not in text
    else:
        assert f"<pre>git checkout {revision}\npip install .\n{command}</pre>" in text
    # An analysis from another revision: the page says so and gives that revision to reproduce it.
    other = balanced_tree.copy()
    other.attrs["source_revision"] = COMMIT
    text = _provenance(hb.report(other))
    assert f"<pre>git checkout {COMMIT}\npip install .\n{command}</pre>" in text
    assert f"analysis by harmbal {hb.__version__} (revision {COMMIT})" in text
    other.attrs["source_revision"] = "unknown"
    text = _provenance(hb.report(other))
    assert "source revision unknown" in text and "<pre>git checkout" not in text and f"<pre>{command}</pre>" in text


def test_archives_store_version_revision_and_command(tmp_path, capsys):
    """Oracle: the root attributes as netCDF4 (not harmbal) reads them, against the command that wrote them."""
    netCDF4 = pytest.importorskip("netCDF4")
    import shlex

    from harmbal._version import source_revision

    scene = str(ENGINES / "v-twin-90.toml")
    commands = {"run": ["run", scene, "-o", str(tmp_path / "run.nc")],
                "loads": ["loads", str(ENGINES / "test-single-loads-gas.toml"), "-o", str(tmp_path / "loads.nc")],
                "sweep": ["sweep", scene, "--set", "piston.mass=0.3,0.4", "-o", str(tmp_path / "sweep.nc")]}
    for name, argv in commands.items():
        assert main(argv) == 0
        with netCDF4.Dataset(tmp_path / f"{name}.nc") as nc:
            assert nc.getncattr("harmbal_version") == hb.__version__
            assert nc.getncattr("source_revision") == source_revision()
            assert nc.getncattr("history") == "harmbal " + shlex.join(argv)
    capsys.readouterr()
