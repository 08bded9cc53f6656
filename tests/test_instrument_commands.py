"""The shipped quick and paper campaigns and `check` on the simulated bench: quick and
`check` from the instruments' power-on state and from a hostile one pass and measure the
same, and every message the drivers send (the paper campaign's too, from power-on) is one
docs/instrument-commands.md lists with its manual section."""

from __future__ import annotations

import functools
import re
from pathlib import Path

import pandas as pd
import pytest
from conftest import recorded_traffic

from squeezebench import paths
from squeezebench.instruments.agilent33120a import Agilent33120A
from squeezebench.instruments.bench import check_bench, sim_bench_config
from squeezebench.instruments.ofv5000 import OFV5000
from squeezebench.instruments.properties import control
from squeezebench.instruments.tds3054b import TDS3054B, Channel
from squeezebench.protocols import campaign

DOC = Path(__file__).resolve().parents[1] / "docs" / "instrument-commands.md"
SECTIONS = {"Agilent 33120A": "generator", "Tektronix TDS 3054B": "scope", "Polytec OFV-5000": "vibrometer",
            "Newport SMC100": "stage"}
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
PLACEHOLDERS = {"<n>": "[1-4]", "<x>": "[12]", "<NR1>": r"[-+]?\d+", "<NR3>": _NUMBER,
                "<range>": r"\d+(?:\.\d+)?(?:mm|m)/s/V"}


def documented() -> dict[str, list[tuple[re.Pattern, str, str]]]:
    """{role: [(pattern of the message form, the form, its manual section)]} from the doc's tables."""
    forms: dict[str, list] = {role: [] for role in SECTIONS.values()}
    role = None
    for line in DOC.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            role = next((r for title, r in SECTIONS.items() if line[3:].startswith(title)), None)
        match = re.match(r"^\| `(.+?)` \| (.*?) \|", line)
        if role and match:
            form, manual = match.group(1).replace("\\|", "|"), match.group(2).strip()
            forms[role].append((re.compile(_pattern(form)), form, manual))
    return forms


def _pattern(form: str) -> str:
    return f"^{_body(form)}$"


def _body(form: str) -> str:
    out, i = "", 0
    while i < len(form):
        token = next((t for t in PLACEHOLDERS if form.startswith(t, i)), None)
        if token:
            out, i = out + PLACEHOLDERS[token], i + len(token)
        elif form[i] == "{":
            end = form.index("}", i)
            out, i = out + "(?:" + "|".join(_body(a) for a in form[i + 1:end].split("|")) + ")", end + 1
        else:
            out, i = out + re.escape(form[i]), i + 1
    return out


def units(message: str) -> list[str]:
    """The units of a message with their full headers (TDS PM p. 2-4: `;` separates units; one
    starting with `:` starts from the root, a star command leaves the branch, any other
    continues the previous unit's branch)."""
    out, branch = [], ""
    for unit in message.split(";"):
        if not unit.startswith("*"):
            if unit.startswith(":"):
                unit = unit[1:]
            elif out and branch:
                unit = f"{branch}:{unit}"
            branch = unit.split(" ", 1)[0].rpartition(":")[0]
        out.append(unit)
    return out


def test_units_are_split_with_their_full_headers():
    assert units("MEASUREMENT:IMMED:SOURCE CH1;TYPE MAXIMUM;VALUE?") == [
        "MEASUREMENT:IMMED:SOURCE CH1", "MEASUREMENT:IMMED:TYPE MAXIMUM", "MEASUREMENT:IMMED:VALUE?"]
    assert units("ACQUIRE:MODE?;*OPC?;NUMAVG?;:HORIZONTAL:MAIN:SCALE?") == [
        "ACQUIRE:MODE?", "*OPC?", "ACQUIRE:NUMAVG?", "HORIZONTAL:MAIN:SCALE?"]
    assert units('MATH:DEFINE "CH1*CH2"') == ['MATH:DEFINE "CH1*CH2"']


def measurements(run_dir: Path) -> pd.DataFrame:
    return pd.concat([pd.read_parquet(p) for p in sorted((run_dir / "measurements").rglob("*.parquet"))])


@pytest.fixture(scope="module")
def runs(tmp_path_factory, quick_run, paper_run):
    """{start: (traffic {role: messages}, {campaign: measurements}, check's lines)} of the
    quick campaign and `check` from each start, and the paper campaign from power-on (the
    session's runs from power-on, `quick_run` and `paper_run`, which the reports' tests also
    read)."""
    results = {}
    for start in ("power_on", "hostile"):
        if start == "power_on":
            run_dir, quick_traffic = quick_run
        else:
            with recorded_traffic() as quick_traffic, pytest.MonkeyPatch.context() as patch:
                patch.setattr(campaign, "sim_bench_config", functools.partial(sim_bench_config, start=start))
                run_dir = campaign.run_campaign(paths.campaigns_dir() / "quick.yaml",
                                                out_dir=tmp_path_factory.mktemp(start) / "quick.yaml", progress=False)
        traffic = {role: list(messages) for role, messages in quick_traffic.items()}
        lines: list[str] = []
        with recorded_traffic() as check_traffic:
            assert check_bench(sim_bench_config(paths.default_scene(), start=start), out=lines.append) == 0, \
                "\n".join(lines)
        for role, messages in check_traffic.items():
            traffic.setdefault(role, []).extend(messages)
        results[start] = (traffic, {"quick.yaml": measurements(run_dir)}, lines)
    # the paper campaign from a hostile start would repeat 40 s of bench to show what quick
    # shows (and test_previous_user_states, from five more starts): the same rows
    paper_dir, paper_traffic = paper_run
    traffic, rows, _ = results["power_on"]
    rows["paper.yaml"] = measurements(paper_dir)
    for role, messages in paper_traffic.items():
        traffic.setdefault(role, []).extend(messages)
    return results


def test_every_message_sent_is_documented_with_its_manual_section(runs):
    forms = documented()
    for role, rows in forms.items():
        assert rows, f"no table for the {role} in {DOC.name}"
        assert all(manual for _, _, manual in rows), f"a {role} command without its manual section"
    for start, (traffic, _, _) in runs.items():
        for role, messages in traffic.items():
            undocumented = sorted({u for m in set(messages) for u in units(m)
                                   if not any(p.match(u) for p, _, _ in forms[role])})
            assert not undocumented, f"{role} ({start}) sent messages not in {DOC.name}: {undocumented}"
    distinct = {role: len(set(messages)) for role, messages in runs["power_on"][0].items()}
    assert set(distinct) == set(SECTIONS.values()) and all(n > 5 for n in distinct.values())


def test_every_driver_command_cites_its_manual_beside_it():
    for cls in (Agilent33120A, TDS3054B, Channel, OFV5000):
        for name, attribute in vars(cls).items():
            if isinstance(attribute, control):
                assert attribute.manual, f"{cls.__name__}.{name} does not cite its manual section"


def test_quick_measures_the_same_from_a_hostile_start(runs):
    columns = ["run_name", "step_id", "point_index", "generator_frequency_hz", "scope_power_w",
               "scope_velocity_pp_v", "vibrometer_scale_mps_per_v"]
    power_on, hostile = (runs[start][1]["quick.yaml"][columns].reset_index(drop=True)
                         for start in ("power_on", "hostile"))
    assert len(power_on) > 50
    pd.testing.assert_frame_equal(power_on, hostile)


def test_check_shows_and_clears_what_a_previous_user_left(runs):
    text = "\n".join(runs["hostile"][2])
    assert "-113,'Undefined header'" in text and "ch2: detected probe TCP202" in text
    assert "decoder = 'VD-09'" in text and text.endswith("bench check passed")
