"""Reduction of stored waveforms, the paper's model, tables, audit, figures, report."""
