"""The HTML page around a report's sections: one Jinja2 template (templates/page.html) and
one style sheet (templates/report.css) for the run report and the design page alike.

The template escapes every text it is given (title, navigation, headings); a section's
body is HTML the report built, passed as markup, and each of its tables is wrapped so
that on a phone a wide table scrolls inside its own box while the page does not.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass

import jinja2
from markupsafe import Markup


@dataclass(frozen=True)
class PageSection:
    anchor: str
    nav: str   # the navigation link's words
    heading: str
    body_html: str
    css_class: str = ""

    @property
    def body(self) -> Markup:
        return Markup(scrolling_tables(self.body_html))


@functools.cache
def _environment() -> jinja2.Environment:
    return jinja2.Environment(loader=jinja2.PackageLoader("squeezebench.report", "templates"),
                              autoescape=True, undefined=jinja2.StrictUndefined, keep_trailing_newline=True)


def render(title: str, sections: list[PageSection], lead_html: str = "") -> str:
    """The whole page: title, optional lead (HTML), navigation, then the sections in order."""
    return _environment().get_template("page.html").render(
        title=title, lead=Markup(lead_html), sections=sections)


def scrolling_tables(body_html: str) -> str:
    """Every table in a box of the page's width that scrolls sideways on its own: on a
    phone a wide table scrolls, the page does not."""
    return re.sub(r"<table\b", "<div class='wide'><table", body_html).replace("</table>", "</table></div>")
