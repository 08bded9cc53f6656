"""Are two source trees' outputs byte-identical? (issue 49: a move must change no output)

For each side (a git revision, checked out with `git worktree add --detach`, or a source
directory) it installs that tree, without dependencies, into its own folder, runs

    python -m squeezebench reproduce --out OUT/paper
    python -m squeezebench design large_plate --from OUT/paper --out OUT/design

with this interpreter's dependencies (the tree's own package first on sys.path: checked),
then compares every file of the report (RUN/report/: index.html, every CSV, headline.txt),
the design page and every CSV and JSON the design writes, byte for byte.

Normalised before comparing, and only this: (1) the side's own absolute folder (each side
installs and writes into its own: the report's provenance names the campaign file of the
installed tree), replaced by `<SIDE>`; (2) ISO 8601 timestamps with a UTC offset
(`2026-11-29T09:52:14+00:00`: the provenance's run created/updated times), replaced by
`<UTC>`. Nothing else is rewritten: any other difference shows. PNG figures are compared
too (matplotlib writes no date into them).

Run: python benchmarks/compare_outputs.py --before main --after HEAD [--work DIR]
     [--reuse] [--no-layouts]
Exit 0 when every file agrees, 1 with the differing files listed.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: What is compared, relative to a side's output folder.
COMPARED_GLOBS = ("paper/report/**/*", "design/**/*")


def checkout(revision_or_dir: str, into: Path) -> Path:
    """The source tree of one side: a directory as given, or a detached worktree of a revision."""
    if Path(revision_or_dir).is_dir():
        return Path(revision_or_dir).resolve()
    if not into.exists():
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(into), revision_or_dir],
                       check=True, stdout=subprocess.DEVNULL)
    return into


def install(tree: Path, site: Path) -> None:
    """The tree installed as a plain (not editable) package into `site`, no dependencies."""
    shutil.rmtree(site, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps",
                    "--target", str(site), str(tree)], check=True)


def run_side(site: Path, out: Path, layouts: bool) -> None:
    env = {**os.environ, "PYTHONPATH": str(site), "SQUEEZEBENCH_CACHE": "off", "MPLBACKEND": "Agg"}
    where = subprocess.run([sys.executable, "-c", "import squeezebench; print(squeezebench.__file__)"],
                           env=env, check=True, capture_output=True, text=True).stdout.strip()
    if not where.startswith(str(site)):
        raise SystemExit(f"{where}: not the tree installed in {site}; refusing to compare")
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    python = [sys.executable, "-m", "squeezebench"]
    subprocess.run([*python, "reproduce", "--out", str(out / "paper")], env=env, check=True, cwd=out,
                   stdout=subprocess.DEVNULL)
    design = [*python, "design", "large_plate", "--from", str(out / "paper"), "--out", str(out / "design")]
    subprocess.run(design + ([] if layouts else ["--no-layouts"]), env=env, check=True, cwd=out,
                   stdout=subprocess.DEVNULL)
    (out / "COMPLETE").write_text("")


#: A run's creation and update times as the provenance shows them.
TIMESTAMP = re.compile(rb"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?[+-]\d\d:\d\d")


def files_of(out: Path) -> dict[str, bytes]:
    found = {}
    side = str(out.parent).encode()
    for pattern in COMPARED_GLOBS:
        for path in sorted(out.glob(pattern)):
            if path.is_file():
                # the only normalisations: this side's own folder, and UTC timestamps
                found[str(path.relative_to(out))] = TIMESTAMP.sub(b"<UTC>", path.read_bytes().replace(side, b"<SIDE>"))
    return found


def compare(before: Path, after: Path) -> list[str]:
    """The relative paths that differ, are missing on one side, or are extra."""
    old, new = files_of(before), files_of(after)
    return [f"{name}: {'only before' if name not in new else 'only after' if name not in old else 'differs'}"
            for name in sorted(old.keys() | new.keys()) if old.get(name) != new.get(name)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default="main", help="git revision or source directory")
    parser.add_argument("--after", default="HEAD", help="git revision or source directory")
    parser.add_argument("--work", type=Path, default=None, help="work folder (default: a temporary one)")
    parser.add_argument("--reuse", action="store_true", help="keep a side's complete earlier outputs")
    parser.add_argument("--no-layouts", action="store_true", help="design --no-layouts on both sides")
    args = parser.parse_args(argv)
    work = (args.work or Path(tempfile.mkdtemp(prefix="compare_outputs_"))).resolve()
    outs = {}
    for label, revision in (("before", args.before), ("after", args.after)):
        side = work / label
        outs[label] = side / "out"
        if args.reuse and (outs[label] / "COMPLETE").is_file():
            continue
        tree = checkout(revision, side / "tree")
        install(tree, side / "site")
        run_side(side / "site", outs[label], layouts=not args.no_layouts)
    differences = compare(outs["before"], outs["after"])
    count = len(files_of(outs["before"]))
    if differences:
        print(f"{len(differences)} of {count} files differ:", *differences, sep="\n  ")
        return 1
    print(f"{count} files byte-identical (report, design page, every CSV, JSON and figure)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
