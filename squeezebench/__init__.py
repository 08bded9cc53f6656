"""squeezebench: bench automation and analysis for ultrasonic squeeze-film tactile plates."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("squeezebench")
except PackageNotFoundError:  # running from a checkout without installation
    __version__ = "0+unknown"
