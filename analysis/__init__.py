"""Analysis of a stored run: a run directory -> quantities -> tables. Reads a run directory
only (never instruments, protocols or simbench), and renders nothing (that is `report`).

- `analysis.rundata`: `load_run(run_dir) -> RunData` (manifest, measurements, scenes).
- `analysis.waveforms`: one record -> power (integer-period mean and sine fit), velocity
  pp, amplitude pp, frequency, each an `Estimate` (value, standard uncertainty).
- `analysis.model`: the paper's Eqs. 12, 25, 27, 28, 29 under an explicit `Convention`.
- `analysis.calibration`: a deskew calibration run as corrections.
- `analysis.tables`: Tables 3 and 4, the detuning and resonance tables recomputed, beside
  the printed values (`squeezebench.paper`); the tables' common rows and fits.
- `analysis.characterisation`: Fig. 5 and Table 5: each plate's Q and tan theta', the
  large plate from the small ones.
- `analysis.budgets`: one value's GUM budget, its terms and k for 95 % from its distribution.
- `analysis.uncertainty`, `analysis.measurement_model`: each stated quantity's budget and
  its measurement model; `analysis.resonance_searches`: the stored searches' settings and Q.
- `analysis.audit`, `analysis.readings`: the paper's inconsistencies and the readings of
  its equations, computed.
- `analysis.cartography`: a vibration map reduced.
- `analysis.study`: the accuracy study's trials as error distributions.
- `analysis.provenance`, `analysis.columns`: where each number comes from; what every column means.

The plate model is `plates`, the pages are `report`.
"""
