"""PyVISA backend shim: `ResourceManager("scene.yaml@simbench")`."""
from squeezebench.simbench.backend import SceneVisaLibrary as WRAPPER_CLASS  # noqa: F401
