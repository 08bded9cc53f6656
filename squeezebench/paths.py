"""Where the shipped data lives (scenes, campaigns, bench examples, the paper's printed values).

The repository's `data/` folder installs as the package `squeezebench.data` (pyproject.toml
maps it), so a wheel carries it and `importlib.resources` finds it wherever the package
is installed, editable or not.
"""

import os
from importlib import resources
from pathlib import Path


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


def paper_values_dir() -> Path:
    return data_dir() / "paper"


def default_scene() -> Path:
    """The scene `--bench sim` uses when none is named: the Table 3 one-column plate."""
    return scenes_dir() / "one_column_1mm.yaml"


def paper_campaign() -> Path:
    return campaigns_dir() / "paper.yaml"
