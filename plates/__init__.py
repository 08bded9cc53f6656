"""The plate model: a free resonator plate with bonded piezos, as pure physics.

Imports no run data, no instrument, protocol or simulator: the simulator (its predicted
scenes), the planner, the analysis and the design import it.

- `plates.plate_modes`: the modal model (Argyris plate elements with Mindlin's correction,
  piezo patches on an epoxy bond): modes, modal mass, force factor, its tolerances.
- `plates.laminate`: the materials, the two-layer laminate, the bond's shear lag, the
  thick-plate (Mindlin) correction.
- `plates.argyris`: scikit-fem's Argyris triangle with its global basis built in one pass.
- `plates.specifications`: the bench's published accuracies and the materials' specified
  tolerances (the Type B inputs of every budget and of the model's tolerances).
- `plates.predicted_plates`: the paper's plates as the model sees them, and what it predicts.
- `plates.damping`: the plate's mechanical Q from the physics of its losses.
- `plates.frequency_budget`: why the predicted and printed resonances differ, term by term.
- `plates.reduced_layouts`: a reduced model that solves many piezo layouts of one plate fast.
"""
