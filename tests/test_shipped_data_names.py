"""The shipped input files (scenes, designs, campaigns, benches, the paper's values) say where
an assumed number comes from by naming a module of this package, or one of its names
(`plates.predicted_plates.MECHANICAL_Q`, `plates/damping.py`). A module that moves leaves
those words pointing nowhere: every one must still import and hold the name it cites."""

from __future__ import annotations

import importlib
import re

from squeezebench.paths import data_dir

#: The package's subpackages, as the files name them (relative to `squeezebench`).
SUBPACKAGES = ("analysis", "plates", "designing", "report", "simbench", "protocols", "instruments")
#: `plates.predicted_plates`, `squeezebench.plates.predicted_plates.MECHANICAL_Q` or `plates/damping.py`.
CITED = re.compile(r"(?<![\w./])(?:squeezebench\.)?(" + "|".join(SUBPACKAGES)
                   + r")[./]([a-z_][a-z_0-9]*)(?:\.py\b)?(?:\.([A-Za-z_][A-Za-z_0-9]*))?")


def cited_names() -> list[tuple[str, str, str, str | None]]:
    """(file, subpackage, module, name or None) for every citation in the shipped files."""
    found, root = [], data_dir()
    for path in sorted(root.rglob("*")):
        if path.suffix in (".yaml", ".csv", ".json", ".md"):
            found += [(str(path.relative_to(root)), *match.groups()) for match in CITED.finditer(path.read_text())]
    return found


def test_the_pattern_reads_a_module_its_name_and_a_file_path_but_not_prose():
    text = ("as plates.predicted_plates.MECHANICAL_Q (plates/damping.py); the analysis. Then "
            "squeezebench.analysis.readings, not other.plates.x")
    assert [m.groups() for m in CITED.finditer(text)] == [
        ("plates", "predicted_plates", "MECHANICAL_Q"), ("plates", "damping", None), ("analysis", "readings", None)]


def test_every_module_a_shipped_file_cites_exists_and_holds_the_cited_name():
    cited = cited_names()
    assert any(module == "predicted_plates" for _, _, module, _ in cited)   # the files do cite modules
    missing = []
    for file, package, module, name in cited:
        try:
            imported = importlib.import_module(f"squeezebench.{package}.{module}")
        except ModuleNotFoundError:
            missing.append(f"{file}: squeezebench.{package}.{module}")
            continue
        if name is not None and not hasattr(imported, name):
            missing.append(f"{file}: squeezebench.{package}.{module}.{name}")
    assert not missing, missing
