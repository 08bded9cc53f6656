"""squeezebench: bench automation and analysis for ultrasonic squeeze-film tactile plates.

The Python API (squeezebench.api) is also here: `squeezebench.resonance_search(...)`.
"""

#: squeezebench.api's functions, imported on first use: the command line stays light.
_API = ("open_bench", "run_protocol", "resonance_search", "characterisation", "run_campaign", "load_run", "design",
        "table3", "table4", "table5")


def __getattr__(name: str):
    # Looked up on first use: the command's entry point takes its stop signals over right
    # after this module loads, and the metadata lookup would leave tens of ms unguarded.
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("squeezebench")
        except PackageNotFoundError:  # running from a checkout without installation
            return "0+unknown"
    if name in _API:
        from squeezebench import api

        return getattr(api, name)
    raise AttributeError(f"module 'squeezebench' has no attribute {name!r}")
