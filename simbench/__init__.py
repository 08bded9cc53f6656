"""The simulated bench: scenes, physics, effects and a virtual clock behind PyVISA."""
