"""The pages: the run report, the design page and the map section, over one page template.

Renders what `analysis` computes from a stored run and what `designing` predicts; imports
no instrument driver and nothing of the command line.

- `report.run_report`: `write_report(run_dir) -> Path` (RUN_DIR/report/index.html), its
  sections in `SECTIONS`.
- `report.headline`: the lines that open the report (headline.txt).
- `report.presentation`: words and numbers as the pages show them.
- `report.figures`, `report.drawing`: the figures, drawn in worker processes.
- `report.page`: the HTML page (templates/page.html, templates/report.css).
- `report.cartography_report`: the map section.
- `report.design_report`: the design page (`squeezebench design`).
- `report.simulated_plates`: the sections on the run's simulated plates (scenes, physics).
"""
