"""The paper's printed values (data/paper/*.csv), each with the table/section it comes from.

Only these files hold numbers typed from the paper; everything else is computed.
"""

from __future__ import annotations

from decimal import Decimal
from functools import lru_cache

import pandas as pd

from squeezebench import paths
from squeezebench.errors import UserError


class PaperValueError(UserError):
    """A printed value the code asks for is not in data/paper/."""


@lru_cache(maxsize=None)
def paper_table(name: str) -> pd.DataFrame:
    """One file of printed values: columns item, quantity, value, unit, source, note, and
    value_text (the value as typed)."""
    path = paths.paper_values_dir() / f"{name}.csv"
    if not path.is_file():
        raise PaperValueError(f"{path}: the paper's printed values are missing")
    frame = pd.read_csv(path, dtype={"item": str, "value": str}, keep_default_na=False)
    frame["value_text"] = frame["value"].str.strip()   # as typed: its last digit is the printed precision
    frame["value"] = frame["value"].astype(float)
    return frame


@lru_cache(maxsize=None)
def _index(name: str) -> dict[tuple[str, str], list[tuple[float, str]]]:
    index: dict[tuple[str, str], list[tuple[float, str]]] = {}
    for row in paper_table(name).itertuples(index=False):
        index.setdefault((row.item, row.quantity), []).append((float(row.value), str(row.source)))
    return index


def _lookup(name: str, item: str, quantity: str) -> tuple[float, str]:
    hits = _index(name).get((item, quantity), [])
    if len(hits) != 1:
        raise PaperValueError(f"data/paper/{name}.csv: expected one row item={item!r} "
                              f"quantity={quantity!r}, found {len(hits)}")
    return hits[0]


def paper_value(name: str, item: str, quantity: str) -> float:
    """One printed value; PaperValueError if it is not listed exactly once."""
    return _lookup(name, item, quantity)[0]


def paper_source(name: str, item: str, quantity: str) -> str:
    """Where the printed value comes from (table, section or figure)."""
    return _lookup(name, item, quantity)[1]


def printed_step(value_text: str) -> float:
    """The step of the printed value's last digit, in its unit: '0.027' -> 0.001,
    '1.08e-6' -> 1e-8; an integer's trailing zeros are not significant ('37160' -> 10)."""
    number = Decimal(value_text)
    if not any(c in value_text for c in ".eE"):
        number = number.normalize()
    return float(Decimal(1).scaleb(number.as_tuple().exponent))
