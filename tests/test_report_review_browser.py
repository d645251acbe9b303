"""The top of the report and its long lines in a real browser (headless
Chromium, as tests/test_report_browser.py: skipped without one unless
``HARMBAL_REQUIRE_BROWSER=1``).

What only a browser can tell: the headline table is on the first screen,
nothing on the page is wider than the window, and a scene line longer than
the provenance box wraps inside it instead of running out of it.
"""

from pathlib import Path

import pytest
from test_report_browser import CHROMIUM_FLAGS, FIRST_SCREEN, _chromium

import harmbal as hb
from harmbal.scene import scene_from_text

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"

pytestmark = pytest.mark.browser

#: A scene line no page is wide enough for: one word of 300 characters in a comment.
LONG_LINE = "# " + "x" * 300


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    binary = _chromium()
    from playwright.sync_api import sync_playwright

    text = (ENGINES / "tractor-3cyl-balanced.toml").read_text(encoding="utf-8") + "\n" + LONG_LINE + "\n"
    path = tmp_path_factory.mktemp("review") / "report.html"
    hb.report(hb.analyse(scene_from_text(text, "tractor-3cyl-balanced.toml")), path)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=binary, args=CHROMIUM_FLAGS)
        view = browser.new_page(viewport=FIRST_SCREEN)
        view.goto(path.as_uri(), wait_until="load")
        yield view
        browser.close()


def test_the_headline_table_is_on_the_first_screen(page):
    box = page.eval_on_selector("#summary table.headline", "e => e.getBoundingClientRect().toJSON()")
    assert 0 < box["top"] < FIRST_SCREEN["height"] / 2
    assert page.inner_text("#summary table.headline th >> nth=0") == "order"


def test_nothing_is_wider_than_the_window(page):
    widths = page.evaluate("() => [document.documentElement.scrollWidth, document.documentElement.clientWidth]")
    assert widths[0] <= widths[1]
    right = page.evaluate("() => Math.max(...[...document.querySelectorAll('table, figure, pre')]"
                          ".map(e => e.getBoundingClientRect().right))")
    body = page.evaluate("() => document.body.getBoundingClientRect().right")
    assert right <= body + 1


def test_a_long_scene_line_wraps_inside_the_provenance_box(page):
    scene_box = page.locator("#provenance pre").last
    assert LONG_LINE[:40] in scene_box.inner_text()
    scroll, client = scene_box.evaluate("e => [e.scrollWidth, e.clientWidth]")
    assert scroll <= client
