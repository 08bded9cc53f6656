"""Analysis of a stored run: reads a run directory only (never instruments, protocols or
simbench).

- `analysis.waveforms`: one record -> power (integer-period mean and sine fit), velocity
  pp, amplitude pp, frequency, each an `Estimate` (value, standard uncertainty).
- `analysis.model`: the paper's Eqs. 12, 25, 27, 28, 29 under an explicit `Convention`.
- `analysis.rundata`: `load_run(run_dir) -> RunData` (manifest, measurements, scenes).
- `squeezebench.paper`: the paper's printed values (data/paper/*.csv) with their source.
- `analysis.tables`: Tables 3, 4, 5 and Fig. 5 recomputed, beside the printed values.
- `analysis.audit`: the paper's inconsistencies and the convention grid, computed.
- `report.figures`: Figs. 2, 5, 8, 9 and resonance curves as PNG.
- `report.run_report`: `write_report(run_dir) -> Path` (RUN_DIR/report/index.html).
"""
