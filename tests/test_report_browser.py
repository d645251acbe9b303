"""The HTML report in a real browser (headless Chromium driven by Playwright).

What a reader sees is checked where only a browser can tell: the page loads
with no console message, no script error and no request beyond the file
itself; every figure is laid out with a non-zero size; the first screen (a
1280 × 800 screenshot) shows the summary with ink in it; printed on A4, every
figure fits on one page and the PDF is made.

Chromium comes from the distribution (``.ci/run`` installs Debian's
``chromium``); ``HARMBAL_CHROMIUM`` names another binary. Without a browser
these tests are skipped, unless ``HARMBAL_REQUIRE_BROWSER=1`` (set by CI),
where a missing browser is a failure.
"""

import io
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"

#: Flags for a sandboxed machine with no network: no background connections.
CHROMIUM_FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]
FIRST_SCREEN = {"width": 1280, "height": 800}
#: A4 at the CSS 96 px/in with the browser's default 1 cm print margins.
A4_CONTENT = {"width": round((210 - 20) / 25.4 * 96), "height": round((297 - 20) / 25.4 * 96)}

pytestmark = pytest.mark.browser


def _chromium() -> str:
    binary = os.environ.get("HARMBAL_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    required = os.environ.get("HARMBAL_REQUIRE_BROWSER") == "1"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        if required:
            pytest.fail("HARMBAL_REQUIRE_BROWSER=1 but Playwright is not installed")
        pytest.skip("Playwright is not installed")
    if binary is None or not Path(binary).exists():
        if required:
            pytest.fail("HARMBAL_REQUIRE_BROWSER=1 but no Chromium was found (set HARMBAL_CHROMIUM)")
        pytest.skip("no Chromium on this machine (CI installs Debian's chromium)")
    return binary


@pytest.fixture(scope="module")
def browser():
    binary = _chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        instance = p.chromium.launch(executable_path=binary, args=CHROMIUM_FLAGS)
        yield instance
        instance.close()


@pytest.fixture(scope="module",
                params=["inline-3-balanced", "lever-single", "tractor-3cyl-gas", "test-single-loads-gas"])
def report_file(request, tmp_path_factory):
    """A report with balancers and verification, one with a lever balancer, one with gas and a flywheel, one
    with bearing and interface loads."""
    path = tmp_path_factory.mktemp("report") / f"{request.param}.html"
    hb.report(hb.analyse(hb.load_scene(ENGINES / f"{request.param}.toml")), path)
    return path


class _Visit:
    """One page load with everything the browser reported on the way."""

    def __init__(self, browser, path: Path, viewport: dict, media: str = "screen"):
        self.page = browser.new_page(viewport=viewport)
        self.console: list[str] = []
        self.errors: list[str] = []
        self.requests: list[str] = []
        self.page.on("console", lambda m: self.console.append(f"{m.type}: {m.text}"))
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.emulate_media(media=media)
        self.page.goto(path.as_uri(), wait_until="load")

    def boxes(self, selector: str) -> list[dict]:
        return self.page.eval_on_selector_all(
            selector, "els => els.map(e => { const r = e.getBoundingClientRect();"
                      " return {name: e.closest('figure')?.dataset.figure, top: r.top + window.scrollY,"
                      " width: r.width, height: r.height}; })")


@pytest.fixture
def visit(browser, report_file):
    made = []

    def load(viewport=FIRST_SCREEN, media="screen"):
        made.append(_Visit(browser, report_file, viewport, media))
        return made[-1]

    yield load
    for v in made:
        v.page.close()


def _figure_names(path: Path) -> list[str]:
    from html.parser import HTMLParser

    names = []

    class Figures(HTMLParser):
        def handle_starttag(self, tag, attrs):
            if tag == "figure":
                names.append(dict(attrs)["data-figure"])

    Figures().feed(path.read_text(encoding="utf-8"))
    return names


def test_page_loads_without_console_messages_errors_or_requests(visit, report_file):
    v = visit()
    assert v.console == []
    assert v.errors == []
    assert v.requests == [report_file.as_uri()]
    assert v.page.title() == f"harmbal report: {hb.load_scene(ENGINES / (report_file.stem + '.toml')).name}"


def test_every_figure_is_drawn_with_nonzero_size(visit, report_file):
    v = visit()
    expected = _figure_names(report_file)
    assert {"spectrum", "stars", "traces", "locus"} <= set(expected)
    boxes = v.boxes("figure > svg")
    assert [b["name"] for b in boxes] == expected
    for box in boxes:
        assert box["width"] > 300 and box["height"] > 100, box
    # Each figure's SVG is complete: the drawing has paths, and its text is laid out as text.
    counts = v.page.eval_on_selector_all(
        "figure > svg", "els => els.map(e => [e.querySelectorAll('path').length, e.querySelectorAll('text').length])")
    for (paths, texts), name in zip(counts, expected):
        assert paths > 10 and texts > 3, name


def test_first_screen_shows_the_summary(visit):
    from matplotlib.image import imread

    v = visit()
    shot = imread(io.BytesIO(v.page.screenshot()), format="png")
    assert shot.shape[:2] == (FIRST_SCREEN["height"], FIRST_SCREEN["width"])
    heading = v.boxes("#summary h2")[0]
    table = v.boxes("#summary table")[0]
    assert v.page.inner_text("#summary h2") == "Summary"
    assert heading["top"] < FIRST_SCREEN["height"] / 4
    assert table["top"] < FIRST_SCREEN["height"] / 2
    # The screenshot has text where the summary table is: dark pixels on the white page.
    top = int(table["top"])
    bottom = min(int(table["top"] + table["height"]), FIRST_SCREEN["height"])
    grey = shot[top:bottom, :, :3].mean(axis=2)
    assert np.mean(grey < 0.5) > 0.01
    assert np.mean(grey > 0.9) > 0.5


def test_printed_on_a4_every_figure_fits_on_one_page(visit, browser, report_file):
    v = visit(viewport=A4_CONTENT, media="print")
    boxes = v.boxes("figure")
    assert boxes
    for box in boxes:
        assert 0 < box["height"] <= A4_CONTENT["height"], box
        assert box["width"] <= A4_CONTENT["width"], box
    pdf = v.page.pdf(format="A4")
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page") > len(boxes) // 3


def test_custom_css_takes_precedence(browser, tmp_path):
    path = tmp_path / "styled.html"
    hb.report(hb.analyse(hb.load_scene(ENGINES / "v-twin-90.toml")), path,
              css="h1 { color: rgb(1, 2, 3); } body { max-width: 80rem; }")
    v = _Visit(browser, path, FIRST_SCREEN)
    try:
        assert v.page.eval_on_selector("h1", "e => getComputedStyle(e).color") == "rgb(1, 2, 3)"
        assert v.page.eval_on_selector("body", "e => getComputedStyle(e).maxWidth") == "1280px"
        assert v.console == [] and v.errors == []
    finally:
        v.page.close()
