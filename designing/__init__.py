"""Designing a plate before it is built (`squeezebench design`).

Named `designing`, not `design`: `squeezebench.design` is the API's function.

- `designing.workflow`: the entry point the command line and the API call
  (`run_design`, `write_build`, `sweep_layouts`, `characterised_plates`).
- `designing.design_file`: a plate to design, as a user draws it (the design file).
- `designing.design`: the physics route, the paper's route from characterised plates,
  the budget and the verdict (`DesignAnswer`).
- `designing.layouts`, `designing.layout_sweep`: the piezo layouts swept, by the reduced model.
- `designing.transfer`: the transfer study (designs checked against simulated builds).
"""
