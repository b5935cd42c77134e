"""Monocular visual guidance for the terminal docking of an AUV onto an LED-ring marker."""

__version__ = "0.1.0"
