"""The marker's colour as a user names it."""

from __future__ import annotations

from auv_dock_guidance.errors import ConfigError

COLOURS = {"blue": (1.0, 0.0, 0.0), "green": (0.0, 1.0, 0.0), "red": (0.0, 0.0, 1.0), "white": (1.0, 1.0, 1.0),
           "cyan": (1.0, 1.0, 0.0), "yellow": (0.0, 1.0, 1.0), "magenta": (1.0, 0.0, 1.0)}


def colour_bgr(text: str) -> tuple[float, float, float]:
    """A colour name or #RRGGBB, as (blue, green, red) shares of its brightest channel."""
    if text.lower() in COLOURS:
        return COLOURS[text.lower()]
    digits = text[1:] if text.startswith("#") else ""
    try:
        r, g, b = (int(digits[i:i + 2], 16) for i in (0, 2, 4)) if len(digits) == 6 else (0, 0, 0)
    except ValueError:
        r = g = b = 0
    if max(r, g, b) == 0:
        raise ConfigError(f"{text!r} is not a colour: give #RRGGBB or one of {', '.join(COLOURS)}")
    top = float(max(r, g, b))
    return b / top, g / top, r / top
