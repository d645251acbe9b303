"""Screenshots of the sample report in docs/report.md, taken in headless Chromium.

Run from the repository root with the test extra installed and Chromium on the
machine (Debian: ``apt-get install chromium``; another binary with
``HARMBAL_CHROMIUM``):

    python docs/make_report_sample.py [--html sample.html]

It analyses ``datasets/engines/inline-3-balanced.toml``, writes its report
(to a temporary file unless ``--html`` names one) and saves the first screen
and the order-spectrum section as PNG files in ``docs/figures/``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

import harmbal as hb

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "datasets" / "engines" / "inline-3-balanced.toml"
FIGURES = ROOT / "docs" / "figures"
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--html", type=Path, help="also keep the sample report there")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    binary = os.environ.get("HARMBAL_CHROMIUM") or shutil.which("chromium")
    with tempfile.TemporaryDirectory() as tmp:
        page_file = args.html or Path(tmp) / "reporting.html"
        hb.report(hb.analyse(hb.load_scene(SCENE)), page_file, source="datasets/engines/inline-3-balanced.toml")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=binary, args=FLAGS)
            page = browser.new_page(viewport={"width": 1100, "height": 760})
            page.goto(page_file.resolve().as_uri())
            page.screenshot(path=FIGURES / "report-first-screen.png")
            page.locator("#figure-spectrum").screenshot(path=FIGURES / "report-spectrum.png")
            browser.close()
    print(f"wrote {FIGURES / 'report-first-screen.png'} and {FIGURES / 'report-spectrum.png'}")


if __name__ == "__main__":
    main()
