"""PyVISA backend shim: `ResourceManager("scene.yaml@simbench")`."""
from simbench.backend import SceneVisaLibrary as WRAPPER_CLASS  # noqa: F401
