"""Designing a plate before it is built (`squeezebench design`).

Named `designing`, not `design`: `squeezebench.design` is the API's function.

- `designing.workflow`: the entry point the command line and the API call
  (`run_design`, `write_build`, `sweep_layouts`, `characterised_plates`).
- `designing.design_file`: a plate to design, as a user draws it (the design file).
- `designing.design`: the physics route (route a): modal part, operating point, budget, placement.
- `designing.paper_route`: the paper's route from characterised small plates (route b).
- `designing.verdict`: neighbour modes, cancellation, feasible / marginal / infeasible.
- `designing.answer`: `DesignAnswer`, both routes with the verdict and the built plate's comparison.
- `designing.layouts`, `designing.layout_sweep`: the piezo layouts swept, by the reduced model.
- `designing.transfer`: the transfer study (designs checked against simulated builds).
"""
