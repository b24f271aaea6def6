"""synth: a physical-modelling string synthesizer.

Digital-waveguide strings at a high internal rate (325 kHz by default) with
pluggable nonlinear contact terminations (capo d'astro, sawari, jawari, or any
user profile), the plucks of Kartofelev's thesis, a block engine with
sample-accurate events and a polyphase decimator to 48 kHz.

Layers (dependencies point down):
    cli, io -> engine -> voices -> physics, kernels;  analysis -> numpy only.
"""

__version__ = "0.1.0"
