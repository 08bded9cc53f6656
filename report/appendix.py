"""The appendix: the conventions the report uses and the run's provenance.
"""

from __future__ import annotations

import html
import json

import numpy as np

import squeezebench
from squeezebench.report.section import ReportContext, Section, cell_text


def conventions_section(context: ReportContext) -> Section:
    """Conventions"""
    c = context.convention
    m = c.materials
    items = [
        f"Convention '{c.name}': V in Eqs. 25/27 is {c.voltage}; A of Eq. 27 is {c.amplitude}; "
        f"neutral plane z0 at the {c.neutral_plane.replace('_', ' ')}; Eq. 28 "
        f"{'with' if c.eq28_with_pi else 'without'} its factor pi; Eq. 29 "
        f"{'as printed (b_large/b_small)' if c.eq29_as_printed else 'with b_small/b_large, as the text describes'}.",
        f"Materials: E_i = {np.format_float_positional(m.resonator_young_pa, trim='-')} Pa, nu_i = {m.resonator_poisson}, "
        f"c11 = {cell_text(m.piezo_c11_pa / 1e9)} GPa, nu_p = {m.piezo_poisson}, d31 = {cell_text(m.piezo_d31_c_per_n * 1e12)} pC/N.",
        "n_c = powered piezos of the plate (measurement column n_powered_piezos); b_p, h_i, h_p and "
        "lambda/2 from the plate's scene copy in inputs/; lambda = 2 (lambda/2).",
        "Power: mean of v i over the largest integer number of periods after DC removal (the paper's "
        "MATH channel), cross-checked by a sine fit. Velocity pp: twice the fitted sine amplitude. "
        "Amplitude pp = velocity pp / (2 pi f).",
        "Uncertainties: U is the expanded uncertainty (k for 95 % under the budget's limits read as rectangles and as the world reads them, analysis.budgets) of the "
        "whole budget of each point "
        "(record noise and the instruments' specifications, analysis.uncertainty); Q and tan theta' "
        "add their fits' uncertainty and the geometry's and NCE 41's tolerances (the systematic parts are "
        "shared by the plates of one bench and do not average down in a mean over plates). A cell agrees "
        "with the paper when the difference is "
        "within U plus half the printed value's last digit.",
        "Q: Eq. 27 with the fitted slope of amplitude pp vs voltage pp. tan theta': Eq. 25 with the "
        "fitted slope of power vs Vpp^2, divided by Q. Table 5 estimate: Q of small_plate_4 through "
        "Eq. 29; tan theta' the mean of the small plates as thick as the large plate.",
        "Origins: measured (real bench), simulated (simulated bench), predicted (simulated bench on a "
        "scene the plate model predicted from geometry and datasheets, no printed result in), calibration input (simulated, "
        "and the scene was calibrated on this printed value: a round trip), derived (computed from "
        "other values), campaign setting (typed into the campaign).",
    ]
    return Section("Conventions used", "<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in items) + "</ul>",
                   "conventions", appendix=True)


def provenance_section(context: ReportContext) -> Section:
    """Provenance"""
    run = context.run
    manifest = run.manifest
    rows = [("run directory", run.run_dir.name),
            ("bench", context.bench()),
            ("report software", f"squeezebench {squeezebench.__version__}"),
            ("run software", json.dumps(manifest.get("software", "not recorded"), sort_keys=True)),
            ("campaign", json.dumps(manifest.get("campaign", "not recorded"), sort_keys=True)),
            ("created (UTC)", str(manifest.get("created_utc", "not recorded"))),
            ("updated (UTC)", str(manifest.get("updated_utc", "not recorded")))]
    recorded = {name: entry.get("sha256") for name, entry in manifest.get("inputs", {}).items()
                if isinstance(entry, dict)}
    for name, digest in run.input_sha256.items():
        state = ("matches manifest" if recorded.get(name) == digest else
                 "NOT the manifest's sha256" if name in recorded else "not in manifest")
        rows.append((f"inputs/{name}", f"sha256 {digest} ({state})"))
    for name, bench in sorted(manifest.get("benches", {}).items()):
        rows.append((f"bench, run {name}", f"{bench.get('bench')} ({bench.get('bench_input')})"))
    for name, scene in sorted(run.scenes.items()):
        replay = scene.get("replay") if isinstance(scene, dict) else None
        rows.append((f"scene {name}", f"replay: {replay.get('reason')}" if isinstance(replay, dict) else
                     "not a replay: within the plate model's bounds, or predicted by it"))
    for name, ids in sorted(manifest.get("instruments", {}).items()):
        rows.append((f"instruments, run {name}", json.dumps(ids, sort_keys=True)))
    counts = run.measurements.groupby("protocol").size() if "protocol" in run.measurements else {}
    for protocol, count in sorted(dict(counts).items()):
        rows.append((f"protocol {protocol}", f"{count} stored points"))
    body = ("<table class='provenance'><caption>Files, digests and instruments of this run.</caption>"
            + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows)
            + "</table><p>Column dictionary of the measurements and CSVs: "
              "<a href='columns.csv'>columns.csv</a> (name, unit, meaning).</p>")
    return Section("Provenance", body, "provenance", appendix=True)
