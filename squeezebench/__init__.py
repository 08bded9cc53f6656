"""squeezebench: bench automation and analysis for ultrasonic squeeze-film tactile plates.

The Python API (squeezebench.api) is also here: `squeezebench.resonance_search(...)`.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("squeezebench")
except PackageNotFoundError:  # running from a checkout without installation
    __version__ = "0+unknown"

#: squeezebench.api's functions, imported on first use: the command line stays light.
_API = ("open_bench", "run_protocol", "resonance_search", "characterisation", "run_campaign", "load_run")


def __getattr__(name: str):
    if name in _API:
        from squeezebench import api

        return getattr(api, name)
    raise AttributeError(f"module 'squeezebench' has no attribute {name!r}")
