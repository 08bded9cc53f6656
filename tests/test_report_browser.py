"""The report of the quick campaign, rendered by headless Chromium at 1280 px: nothing
wider than the page, every image loaded and captioned, every table captioned, the
dry run said on every table of results.

Chromium is required: without it the test fails (CI installs it; `apt-get install -y
chromium`), because a skipped layout test would pass a report nobody looked at.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import squeezebench.simulated_plates  # noqa: F401  (the report as the command line writes it)
from squeezebench import paths
from squeezebench.analysis import report
from squeezebench.protocols.campaign import run_campaign

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs"))
import make_screenshots  # noqa: E402  (docs/ is not a package)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    make_screenshots.chromium()   # FileNotFoundError (a failure, not a skip) without a browser
    run_dir = run_campaign(paths.campaigns_dir() / "quick.yaml", out_dir=tmp_path_factory.mktemp("quick") / "run",
                           progress=False)
    index = report.write_report(run_dir)
    return make_screenshots.measure(index)


def test_nothing_is_wider_than_the_page(rendered):
    width = rendered["viewport"]
    assert width == make_screenshots.WIDTH_PX
    assert rendered["scroll_width"] <= width, "the page scrolls sideways"
    for image in rendered["images"]:
        assert image["loaded"], image["src"]
        assert image["right"] <= width and image["left"] >= 0, image
    for table in rendered["tables"]:
        assert table["right"] <= width, table["caption"]


def test_every_figure_and_table_has_a_caption(rendered):
    assert rendered["images"], "the quick campaign's report has figures"
    for image in rendered["images"]:
        assert image["caption"].startswith("Report figure"), image["src"]
        assert len(image["caption"]) > 60, image   # says what, which runs, what the paper shows
    for table in rendered["tables"]:
        assert table["caption"], table


def test_the_dry_run_is_said_on_every_results_table(rendered):
    results = [t for t in rendered["tables"] if "Table 3" in t["caption"] or "Fig. 2" in t["caption"]]
    assert results
    for table in results:
        assert "Dry run: simulated bench." in table["caption"], table["caption"]
