"""Where each number of a run comes from (brief, principle 3): which bench produced a
stored row, and which published readings a simulated scene was calibrated on.

Origins, as the report and the tables' `origin` column name them:
- `measured`: read on a real bench (rows with `bench` = "real");
- `simulated`: read on the simulated bench, where the scene's physics answered;
- `predicted`: read on the simulated bench from a predicted scene state (its resonance,
  mode and coupling from the plate model: geometry and datasheets, no printed result in),
  what a lab would measure if the model is right;
- `calibration input`: simulated, but the scene state was calibrated on this very
  published reading, so the value is the round trip of a printed number, not a result;
- `derived`: computed from other values (Q, tan theta', the Table 5 estimate); a derived
  value is also a round trip when one of its inputs is a calibration input;
- `paper`: printed in the paper (data/paper/);
- `campaign setting`: typed into the campaign file (e.g. the antinodes of a cut length).

Stored rows carry `bench`, `bench_input` (the scene or bench file's copy under inputs/),
`bench_input_sha256` and `instrument_ids` (protocols.storage.bench_provenance); a run
written before those columns existed is "not recorded", never "measured".
"""

from __future__ import annotations

import pandas as pd

from squeezebench.analysis.rundata import RunData

MEASURED = "measured"
SIMULATED = "simulated"
PREDICTED = "predicted"
CALIBRATION_INPUT = "calibration input"
DERIVED = "derived"
PAPER = "paper"
SETTING = "campaign setting"
NOT_RECORDED = "bench not recorded"

#: Scene state keys (simbench scene schema) that pin a table quantity to a printed value.
_STATE_KEYS = {"resonance_frequency_hz": "frequency_hz", "voltage_vpp": "voltage_vpp",
               "power_w": "power_w", "velocity_pp_mps": "velocity_pp_mps",
               "amplitude_pp_m": "amplitude_pp_m", "q": "q", "tan_theta": "tan_theta"}
#: What each quantity is computed from: calibrating any of these makes it a round trip
#: (amplitude pp = velocity pp / (2 pi f); Q from the amplitude, Eq. 27; tan theta' from
#: the power and Q, Eq. 25).
_DEPENDS_ON = {"amplitude_pp_m": {"velocity_pp_mps"}, "velocity_pp_mps": {"amplitude_pp_m"},
               "q": {"amplitude_pp_m", "velocity_pp_mps"},
               "tan_theta": {"power_w", "q", "amplitude_pp_m", "velocity_pp_mps"}}


def bench_kind(rows: pd.DataFrame, manifest: dict | None = None) -> str:
    """"simulated", "real", "simulated and real", or NOT_RECORDED for `rows`."""
    kinds: set[str] = set()
    if "bench" in rows:
        kinds = {str(k) for k in rows["bench"].dropna().unique()}
    elif manifest and "run_name" in rows:
        benches = manifest.get("benches", {})
        kinds = {benches[r]["bench"] for r in rows["run_name"].unique() if r in benches}
    if not kinds:
        return NOT_RECORDED
    return " and ".join(sorted(kinds))


def point_origin(rows: pd.DataFrame, manifest: dict | None = None, scenes: dict | None = None) -> str:
    """The origin of a value read directly from `rows` (before any calibration check);
    with the run's `scenes` (RunData.scenes), simulated rows whose every scene state is a
    predicted one are PREDICTED."""
    kind = bench_kind(rows, manifest)
    if kind == "simulated" and scenes and not rows.empty and all(
            _state_of(scenes, scene, state).get("resonance_frequency_hz") == "predicted"
            for (scene, state), _ in rows.groupby([scene_files(rows), _state_column(rows)], dropna=False)):
        return PREDICTED
    return {"real": MEASURED, "simulated": SIMULATED}.get(kind, kind)


def scene_states(scene) -> dict[str, dict]:
    """A stored scene's states (RunData.scenes values are parsed YAML: anything a file held)."""
    states = scene.get("states") if isinstance(scene, dict) else None
    return {name: state for name, state in states.items() if isinstance(state, dict)} \
        if isinstance(states, dict) else {}


def _state_of(scenes: dict, scene_name: str, state_name) -> dict:
    """The scene state a row ran in (the scene's initial state when the row names none)."""
    scene = scenes.get(scene_name, {})
    initial = scene.get("initial_state") if isinstance(scene, dict) else None
    return scene_states(scene).get(state_name if isinstance(state_name, str) and state_name else initial, {})


def calibrated_on(run: RunData, rows: pd.DataFrame) -> dict[str, str]:
    """quantity -> where a scene of `rows` took it from a printed value, e.g.
    'one_column_1mm.yaml state 75x41: power_w = 0.027' (simulated rows only). A quantity
    computed from calibrated ones is listed too, naming those inputs."""
    if rows.empty or bench_kind(rows, run.manifest) != "simulated":
        return {}
    direct: dict[str, list[str]] = {}
    for (scene_name, state_name), _ in rows.groupby([scene_files(rows), _state_column(rows)],
                                                    dropna=False, sort=True):
        scene = run.scenes.get(scene_name, {})
        state_key = state_name if isinstance(state_name, str) and state_name else scene.get("initial_state")
        for key, value in _calibration_items(_state_of(run.scenes, scene_name, state_name)):
            if key in _STATE_KEYS:
                direct.setdefault(_STATE_KEYS[key], []).append(
                    f"{scene_name} state {state_key}: {key} = {value:g}")
    found = {quantity: "; ".join(dict.fromkeys(where)) for quantity, where in direct.items()}
    for quantity, inputs in _DEPENDS_ON.items():
        sources = [s for i in sorted(inputs) if i in direct for s in direct[i]]
        if quantity not in found and sources:
            found[quantity] = "; ".join(dict.fromkeys(sources))
    return found


def _calibration_items(state: dict):
    """(key, number) of a scene state: its resonance frequency and every number in its
    `calibration` section (nested sections, e.g. a paper-model calibration, flattened)."""
    if not isinstance(state, dict):
        return
    if isinstance(state.get("resonance_frequency_hz"), (int, float)):
        yield "resonance_frequency_hz", float(state["resonance_frequency_hz"])
    stack = [state.get("calibration", {})]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            for key, value in node.items():
                if isinstance(value, dict):
                    stack.append(value)
                elif isinstance(value, (int, float)) and not isinstance(value, bool):
                    yield key, float(value)


def scene_files(rows: pd.DataFrame) -> pd.Series:
    """The scene file each row ran on (its inputs/ copy name); older rows: the plate's name."""
    if "bench_input" in rows:
        return rows["bench_input"].map(lambda p: str(p).removeprefix("inputs/"))
    return rows["plate"].map(lambda p: f"{p}.yaml")


def _state_column(rows: pd.DataFrame) -> pd.Series:
    return rows["scene_state"] if "scene_state" in rows else pd.Series("", index=rows.index)
