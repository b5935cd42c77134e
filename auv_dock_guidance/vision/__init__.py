"""Marker detection: improved Canny edges, adaptive threshold, interference rejection."""
