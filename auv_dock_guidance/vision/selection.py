"""Which bright region is the dock's ring (paper section 2.3, Fig. 5), and which are not.

Gates first drop what cannot be the marker: too small for the farthest range we accept
(glints, speckle, distant lamps), too elongated (streaks), without a real edge around it
(haze, glow), or with an outline no ellipse fits (caustics, structure: a circle seen at
any angle is an ellipse). Where the frame cuts an outline, its shape says little; what
is left must still bend through most of a half circle. Among the rest the paper's rule chooses: the largest closed
contour, and when several are about equally large the lowest in the image, because a
surface reflection always appears above the light it mirrors. Two additions: a region
with the ring's dark centre beats a solid blob, so a lamp cannot win on size alone once
the ring is resolved; and regions much dimmer than the brightest of their kind are not
the LEDs but light the water made (caustics, glow on structure), so they do not compete.
A surface reflection is nearly as bright as the ring and still meets the tie rule.
"""

from __future__ import annotations

from dataclasses import dataclass

from auv_dock_guidance.errors import ConfigError


@dataclass(frozen=True)
class SelectionConfig:
    """Gates and tie rule. Sizes in full-resolution pixels."""

    min_radius_px: float = 3.0  # smaller: a glint or speckle
    min_hole_fraction: float = 0.12  # hole area / outer area for a region to count as a ring
    min_axis_ratio: float = 0.25  # minor / major axis; below: a streak, not a ring
    min_edge_support: float = 0.8  # share of the outline on an improved-Canny edge (LEDs are sharp lights)
    max_ellipse_residual: float = 0.05  # rms distance of the outline from its ellipse / mean radius
    min_cut_arc_deg: float = 150.0  # of its circle an outline the frame cuts must cover (a streak covers little)
    min_contrast_share: float = 0.35  # dimmer than this share of the brightest of its kind: not the LEDs
    tie_ratio: float = 0.7  # areas within this ratio of the largest are "equally large"
    prefer_rings: bool = True

    def __post_init__(self) -> None:
        if not 0.0 < self.tie_ratio <= 1.0:
            raise ConfigError(f"tie_ratio {self.tie_ratio} must be in (0, 1]")
        if self.min_radius_px < 0 or not 0.0 <= self.min_hole_fraction < 1.0:
            raise ConfigError("min_radius_px must be >= 0 and min_hole_fraction in [0, 1)")
        if not 0.0 <= self.min_axis_ratio <= 1.0 or not 0.0 <= self.min_edge_support <= 1.0:
            raise ConfigError("min_axis_ratio and min_edge_support must be in [0, 1]")
        if not self.max_ellipse_residual > 0 or not 0.0 <= self.min_contrast_share <= 1.0:
            raise ConfigError("max_ellipse_residual must be positive and min_contrast_share in [0, 1]")


@dataclass(frozen=True)
class CandidateShape:
    """What selection needs to know of one closed region (full-resolution units)."""

    area_px: float
    center_v: float
    radius_px: float
    axis_ratio: float
    hole_fraction: float
    edge_support: float
    contrast: float = 0.0  # mean grey level of the region above its surroundings
    ellipse_residual: float = 0.0  # rms distance of the outline from its fitted ellipse / mean radius
    arc_deg: float = 360.0  # how much of a circle the outline covers (less only where the frame cuts it)


def rejection_reason(shape: CandidateShape, config: SelectionConfig, min_radius_px: float) -> str | None:
    """Why a region cannot be the marker, or None when it passes every gate."""
    if shape.radius_px < max(config.min_radius_px, min_radius_px):
        return f"radius {shape.radius_px:.1f} px below {max(config.min_radius_px, min_radius_px):.1f} px"
    if shape.axis_ratio < config.min_axis_ratio:
        return f"elongated (axis ratio {shape.axis_ratio:.2f})"
    if shape.edge_support < config.min_edge_support:
        return f"no sharp outline (edge support {shape.edge_support:.2f})"
    if shape.arc_deg < config.min_cut_arc_deg:
        return f"an open arc the frame cut ({shape.arc_deg:.0f} deg of a circle)"
    if shape.ellipse_residual > config.max_ellipse_residual:
        return f"not an ellipse (outline off by {100 * shape.ellipse_residual:.0f} % of its radius)"
    return None


def is_ring(shape: CandidateShape, config: SelectionConfig) -> bool:
    return shape.hole_fraction >= config.min_hole_fraction


def choose(shapes: list[CandidateShape], config: SelectionConfig) -> int | None:
    """Index of the marker among regions that passed the gates (paper Fig. 5), or None."""
    if not shapes:
        return None
    pool = list(range(len(shapes)))
    if config.prefer_rings:
        rings = [i for i in pool if is_ring(shapes[i], config)]
        pool = rings or pool
    brightest = max(shapes[i].contrast for i in pool)
    # Regions no brighter than the water about them (contrast <= 0) or of no measurable contrast would all
    # fail a share of the brightest: then the brightest stay (open water crashed here on such a frame).
    pool = [i for i in pool if shapes[i].contrast >= config.min_contrast_share * brightest] or [
        i for i in pool if shapes[i].contrast == brightest] or pool
    largest = max(shapes[i].area_px for i in pool)
    tied = [i for i in pool if shapes[i].area_px >= config.tie_ratio * largest]
    return max(tied, key=lambda i: shapes[i].center_v)
