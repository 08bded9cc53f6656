"""The design page of a small plate with a column at each end, rendered by headless
Chromium at 1280 px and 390 px: nothing wider than the page, every figure (the mode, power
against voltage, the placement curve) loaded and captioned, the answer and its verdict on
the first screen. Chromium is required (a failure without it, as the report's browser test)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from squeezebench import cli
from squeezebench.yamlfiles import dump_yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs"))
import make_screenshots  # noqa: E402  (docs/ is not a package)
from test_design import ENDS  # noqa: E402

WIDTHS = (make_screenshots.WIDTH_PX, make_screenshots.PHONE_WIDTH_PX)


@pytest.fixture(scope="module")
def widths(tmp_path_factory):
    make_screenshots.chromium()
    folder = tmp_path_factory.mktemp("design")
    (folder / "ends.yaml").write_text(dump_yaml(ENDS))
    assert cli.main(["design", str(folder / "ends.yaml"), "--no-layouts", "--out", str(folder / "page"), "-q"]) == 0
    return make_screenshots.measure_widths(folder / "page" / "index.html", WIDTHS)   # one Chromium for both


@pytest.mark.parametrize("width", WIDTHS)
def test_design_page_fits_laptop_and_phone(widths, width):
    rendered = widths[width]
    assert rendered["scroll_width"] <= width, "the page scrolls sideways"
    assert sorted(image["src"] for image in rendered["images"]) == ["mode.png", "placement.png", "power_voltage.png"]
    for image in rendered["images"]:
        assert image["loaded"] and image["right"] <= width, image
        assert image["caption"], image["src"]
    for table in rendered["tables"]:
        assert table["right"] <= width and table["caption"], table


def test_the_answer_is_on_the_first_screen(widths):
    first = widths[make_screenshots.WIDTH_PX]["tables"][0]
    assert first["top"] < 800, first
