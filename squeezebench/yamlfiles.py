"""Reading YAML strictly: one loader for every file the project reads (campaigns, bench
files, scenes). PyYAML's SafeLoader silently keeps the last of a key given twice (a scene
with `amplifier_gain: 20` then `40` runs at 40) and accepts `.nan` and `.inf`; this one
refuses both, naming the line. `dump_yaml` writes the files the project makes itself
(scene and campaign variants), in the order given.
"""

from __future__ import annotations

import copy
import functools
import math
import re
from pathlib import Path
from typing import Any

import yaml

from squeezebench.errors import UserError


class FileFormatError(UserError):
    """A file that is not the UTF-8 YAML it should be (or repeats a key, or holds NaN/inf)."""


# -- reading YAML strictly ---------------------------------------------------------------
class _StrictLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
    """SafeLoader refusing duplicate keys and non-finite numbers; on libyaml's parser where
    PyYAML has it (the pure-Python one takes some 50 ms per scene file)."""


def _mapping(loader: _StrictLoader, node: yaml.MappingNode) -> dict:
    loader.flatten_mapping(node)
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"key '{key}' is given twice (lines {seen[key] + 1} and "
                f"{key_node.start_mark.line + 1}); give it once", key_node.start_mark)
        seen[key] = key_node.start_mark.line
    return loader.construct_mapping(node, deep=True)


def _float(loader: _StrictLoader, node: yaml.ScalarNode) -> float:
    value = yaml.SafeLoader.construct_yaml_float(loader, node)
    if not math.isfinite(value):
        raise yaml.constructor.ConstructorError(
            None, None, f"'{node.value}' is not allowed: every number must be finite", node.start_mark)
    return value


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)
_StrictLoader.add_constructor("tag:yaml.org,2002:float", _float)
# YAML 1.1 reads an exponent without a dot (1e-6) as text; YAML 1.2, Python and every
# person read a number, and a design file's 1 µm is written so.
_StrictLoader.add_implicit_resolver("tag:yaml.org,2002:float",
                                    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
                                    list("-+0123456789."))


def read_yaml(path: Path) -> Any:
    """The file's YAML, or FileFormatError naming the file and the cause (line, column)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"{path}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                              f"{exc.start}); save it as UTF-8") from None
    try:
        return load_strict(text)
    except yaml.YAMLError as exc:
        raise FileFormatError(f"{path}: {yaml_problem(exc)}") from None


def yaml_problem(exc: yaml.YAMLError) -> str:
    """One line: where the YAML is wrong and why (PyYAML's own text spans several)."""
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    return f"not valid YAML{where}: {getattr(exc, 'problem', None) or exc}"


def load_strict(text: str) -> Any:
    """YAML text through the strict loader (yaml.YAMLError on a repeated key or NaN/inf):
    a copy of what the same text gave before in this process, since the studies and the
    planner open a bench per trial, each reading its scene and bench files again (a copy
    costs a tenth of a parse, and the caller may change it)."""
    return copy.deepcopy(_parsed(text))


@functools.lru_cache(maxsize=64)
def _parsed(text: str) -> Any:
    return yaml.load(text, Loader=_StrictLoader)


def dump_yaml(data: Any) -> str:
    """`data` as safe YAML, keys in the order given: PyYAML's safe_dump on libyaml's emitter
    where PyYAML has it (the same text, about 6x faster: the studies write a scene per bench)."""
    return yaml.dump(data, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper), sort_keys=False)
