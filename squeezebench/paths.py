"""Where the shipped data lives (scenes, campaigns, bench examples, the paper's printed values).

The repository's `data/` folder installs as the package `squeezebench.data` (pyproject.toml
maps it), so a wheel carries it and `importlib.resources` finds it wherever the package
is installed, editable or not.
"""

import os
from importlib import resources
from pathlib import Path

from squeezebench.errors import UserError


def data_dir() -> Path:
    """The shipped `data/` folder; `SQUEEZEBENCH_DATA` overrides it."""
    override = os.environ.get("SQUEEZEBENCH_DATA")
    if override:
        return Path(override)
    # A package installed from a wheel or a checkout is a folder on disk: the
    # resource root is a real path that scenes and campaigns can name.
    return Path(str(resources.files("squeezebench.data")))


def state_dir() -> Path:
    """Where squeezebench keeps what must outlive a process (the drive record of each
    generator, protocols.drive_record): `SQUEEZEBENCH_STATE`, else $XDG_STATE_HOME/squeezebench,
    else ~/.local/state/squeezebench."""
    override = os.environ.get("SQUEEZEBENCH_STATE")
    if override:
        return Path(override)
    return Path(os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state") / "squeezebench"


def scenes_dir() -> Path:
    return data_dir() / "scenes"


def campaigns_dir() -> Path:
    return data_dir() / "campaigns"


def campaign_file(name: str | Path) -> Path:
    """A campaign file as given, else a campaign shipped with squeezebench (`quick`,
    `paper.yaml`): an installed package has no data/ folder in the working directory. A
    folder of the same name (a run directory called `quick`) does not hide a shipped one."""
    return _given_or_shipped(name, campaigns_dir())   # the campaign loader names what is missing


def input_file(name: str | Path) -> Path:
    """A file as given, else a shipped campaign, scene, bench or design file of that name (with or
    without `.yaml`): what `validate` accepts, as `run` accepts a shipped campaign's name."""
    return _given_or_shipped(name, campaigns_dir(), scenes_dir(), benches_dir(), designs_dir())


def designs_dir() -> Path:
    """Plates to design (`squeezebench design NAME`): the paper's large plate as drawn."""
    return data_dir() / "designs"


def design_template() -> Path:
    """The worked example of docs/design-files.md (`squeezebench design --template`)."""
    return data_dir() / "examples" / "design_template.yaml"


def design_file(name: str | Path) -> Path:
    """A design file as given, else a shipped design of that name (with or without `.yaml`)."""
    return _given_or_shipped(name, designs_dir())


def _given_or_shipped(name: str | Path, *folders: Path) -> Path:
    """`name` if it is a file, else the first of folders/name or folders/name.yaml that is
    one, else `name` as given (its reader names what is missing)."""
    path = Path(name)
    if path.is_file():
        return path
    for folder in folders:
        for candidate in (folder / path, folder / f"{path}.yaml"):
            if candidate.is_file():
                return candidate
    return path


def benches_dir() -> Path:
    """Bench file examples to copy and fill in with a lab's VISA addresses."""
    return data_dir() / "benches"


#: What `squeezebench list KIND` lists: each kind of shipped file and its folder.
SHIPPED_KINDS = {"campaigns": campaigns_dir, "scenes": scenes_dir, "designs": designs_dir, "benches": benches_dir}
#: One of each kind, as a message names it.
KIND_SINGULAR = {"campaigns": "campaign", "scenes": "scene", "designs": "design", "benches": "bench"}


def shipped(kind: str) -> list[Path]:
    """The shipped files of one kind (`SHIPPED_KINDS`), sorted by name."""
    return sorted(SHIPPED_KINDS[kind]().glob("*.yaml"))


def shipped_names(kind: str) -> list[str]:
    return [path.stem for path in shipped(kind)]


def shipped_of_kind(name: str | Path, kind: str) -> Path:
    """`name` as a file, else the shipped file of that kind and name; a name that is neither
    is a UserError naming the shipped ones of that kind, with the closest as a guess."""
    path = _given_or_shipped(name, SHIPPED_KINDS[kind]())
    if path.is_file():
        return path
    raise UserError(unknown_name(str(name), [kind]))


def unknown_name(name: str, kinds: list[str]) -> str:
    """"no file X, and no shipped campaign of that name; did you mean 'quick'? shipped
    campaigns: ..." (difflib's closest names of those kinds)."""
    import difflib

    known = {kind: shipped_names(kind) for kind in kinds}
    stem = Path(name).stem if name.endswith((".yaml", ".yml")) else name
    guesses = difflib.get_close_matches(stem, [n for names in known.values() for n in names], n=1)
    guess = f"; did you mean '{guesses[0]}'?" if guesses else ""
    what = " or ".join(KIND_SINGULAR[kind] for kind in kinds)
    listed = "; ".join(f"shipped {kind}: {', '.join(names)}" for kind, names in known.items())
    return f"{name}: no such file, and no shipped {what} of that name{guess} ({listed}; `squeezebench list` shows them)"


def paper_values_dir() -> Path:
    return data_dir() / "paper"


def default_scene() -> Path:
    """The scene `--bench sim` uses when none is named: the Table 3 one-column plate."""
    return scenes_dir() / "one_column_1mm.yaml"


def paper_campaign() -> Path:
    return campaigns_dir() / "paper.yaml"
