"""Shipped data, installed as `squeezebench.data`: read through `squeezebench.paths`."""
