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
`<UTC>`; (3) with `--module-renames`, the paths of the modules issue 49 moved
(`MODULE_RENAMES`, e.g. `analysis.specifications` -> `plates.specifications`, also in
slash form), rewritten to the new ones on both sides: a few explanations in the outputs
name the module a number comes from (and the shipped data files named the old ones until
they were brought up to date after the move). Each file is reported with the normalisations it needed.
Nothing else is rewritten: any other difference shows. PNG figures are compared too
(matplotlib writes no date into them).

Run: python benchmarks/compare_outputs.py --before main --after HEAD [--work DIR]
     [--reuse] [--no-layouts] [--module-renames]
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
#: The modules issue 49 moved (old -> new, relative to squeezebench), whose paths some
#: explanations in the outputs name.
MODULE_RENAMES = {
    **{f"analysis.{name}": f"plates.{name}" for name in (
        "plate_modes", "argyris", "specifications", "predicted_plates", "damping", "frequency_budget",
        "reduced_layouts")},
    "analysis.paper": "squeezebench.paper",
    **{f"analysis.{name}": f"designing.{name}" for name in ("design", "design_file", "layouts", "layout_sweep")},
    "squeezebench.designing": "designing.workflow", "squeezebench.design_transfer": "designing.transfer",
    "analysis.report": "report.run_report",
    **{f"analysis.{name}": f"report.{name}" for name in (
        "design_report", "cartography_report", "page", "presentation", "drawing", "figures", "headline")},
    "squeezebench.simulated_plates": "report.simulated_plates",
}


def _renamed(data: bytes) -> bytes:
    """`data` with the moved modules' old paths (dotted, or as files: analysis/x.py) made new."""
    def new(match: re.Match) -> bytes:
        old, dot = match.group(1).decode(), match.group(2) or b""
        key = old.replace("/", ".")
        target = MODULE_RENAMES[key]
        return (target.replace(".", "/") if "/" in old else target).encode() + dot
    names = sorted(MODULE_RENAMES, key=len, reverse=True)
    forms = [re.escape(name) for name in names] + [re.escape(name.replace(".", "/")) for name in names]
    return re.sub(rb"(?<![\w./])(" + "|".join(forms).encode() + rb")\b(\.py)?(?![\w/])", new, data)


def files_of(out: Path, renames: bool = False) -> dict[str, bytes]:
    found = {}
    side = str(out.parent).encode()
    for pattern in COMPARED_GLOBS:
        for path in sorted(out.glob(pattern)):
            if path.is_file():
                # the only normalisations: this side's own folder, UTC timestamps, moved modules' paths
                data = TIMESTAMP.sub(b"<UTC>", path.read_bytes().replace(side, b"<SIDE>"))
                found[str(path.relative_to(out))] = _renamed(data) if renames else data
    return found


def compare(before: Path, after: Path, renames: bool = False) -> tuple[list[str], list[str]]:
    """The relative paths that differ, are missing on one side, or are extra; and those that
    agree only once the moved modules' paths are renamed (with `renames`)."""
    old, new = files_of(before), files_of(after)
    old_renamed, new_renamed = (files_of(before, True), files_of(after, True)) if renames else (old, new)
    differ = [f"{name}: {'only before' if name not in new else 'only after' if name not in old else 'differs'}"
              for name in sorted(old.keys() | new.keys()) if old_renamed.get(name) != new_renamed.get(name)]
    only_renamed = [name for name in sorted(old.keys() & new.keys())
                    if old[name] != new[name] and old_renamed[name] == new_renamed[name]]
    return differ, only_renamed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default="main", help="git revision or source directory")
    parser.add_argument("--after", default="HEAD", help="git revision or source directory")
    parser.add_argument("--work", type=Path, default=None, help="work folder (default: a temporary one)")
    parser.add_argument("--reuse", action="store_true", help="keep a side's complete earlier outputs")
    parser.add_argument("--no-layouts", action="store_true", help="design --no-layouts on both sides")
    parser.add_argument("--module-renames", action="store_true",
                        help="rename the moved modules' old paths to the new ones in both sides' text (MODULE_RENAMES)")
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
    differences, only_renamed = compare(outs["before"], outs["after"], renames=args.module_renames)
    count = len(files_of(outs["before"]))
    if only_renamed:
        print(f"{len(only_renamed)} files agree once the moved modules' paths are renamed:", *only_renamed,
              sep="\n  ")
    if differences:
        print(f"{len(differences)} of {count} files differ:", *differences, sep="\n  ")
        return 1
    print(f"{count - len(only_renamed)} of {count} files byte-identical (report, design page, every CSV, JSON and "
          f"figure){', the others as said above' if only_renamed else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
