"""Synthetic scenes and (later) the closed-loop docking simulator."""
