"""The paper's adaptive threshold (section 2.2, Fig. 4), steered by the marker's apparent size.

The threshold is a grey level between the local background and the marker's peak:
``T = background + fraction * (peak - background)``. The fraction is what adapts:

* marker small (far): a low fraction finds faint light and keeps its whole glow;
* marker large (near): a high fraction segments the LEDs themselves, not their halo;
* marker lost: the fraction steps down frame by frame (search has priority when far);
* a floor, ``background + max(floor_grey, floor_noise_sigmas * noise)``, stops a low
  threshold from segmenting noise and backscatter (over-detection).

The fraction follows the size on a log scale around a reference radius (the apparent size
at an intermediate distance) and moves at most ``max_step`` per frame, so one odd frame
cannot swing the segmentation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from auv_dock_guidance.errors import ConfigError


@dataclass(frozen=True)
class ThresholdConfig:
    """Parameters of the adaptive threshold. Radii are in full-resolution pixels."""

    reference_radius_px: float = 80.0  # apparent ring radius at an intermediate range (~7.5 m, R 0.35 m)
    fraction_at_reference: float = 0.4  # threshold as a share of (peak - background) there
    fraction_per_octave: float = 0.1  # change of the share per doubling of the apparent radius
    fraction_far: float = 0.2  # lowest share: faint, far light
    fraction_near: float = 0.6  # highest share: the LEDs, not the halo
    max_step: float = 0.05  # largest change of the share from one frame to the next
    floor_grey: float = 8.0  # the threshold is never closer than this to the background...
    floor_noise_sigmas: float = 5.0  # ...nor than this many noise standard deviations

    def __post_init__(self) -> None:
        if self.reference_radius_px <= 0:
            raise ConfigError(f"reference_radius_px {self.reference_radius_px} must be positive")
        if not 0.0 < self.fraction_far <= self.fraction_at_reference <= self.fraction_near < 1.0:
            raise ConfigError(
                "need 0 < fraction_far <= fraction_at_reference <= fraction_near < 1, got "
                f"{self.fraction_far}, {self.fraction_at_reference}, {self.fraction_near}"
            )
        if self.max_step <= 0 or self.floor_grey < 0 or self.floor_noise_sigmas < 0:
            raise ConfigError("max_step must be positive; floor_grey and floor_noise_sigmas not negative")


class AdaptiveThreshold:
    """Threshold state carried across the frames of one sequence."""

    def __init__(self, config: ThresholdConfig = ThresholdConfig()) -> None:
        self.config = config
        self._fraction: float | None = None

    @property
    def fraction(self) -> float | None:
        """The current share of (peak - background); None before the first frame."""
        return self._fraction

    def reset(self) -> None:
        self._fraction = None

    def target_fraction(self, radius_px: float) -> float:
        """The share that suits a marker of this apparent radius."""
        c = self.config
        octaves = math.log2(max(radius_px, 1e-3) / c.reference_radius_px)
        share = c.fraction_at_reference + c.fraction_per_octave * octaves
        return min(c.fraction_near, max(c.fraction_far, share))

    def fraction_for(self, radius_estimate_px: float) -> float:
        """The share to use on this frame for a candidate of the estimated size (not stored)."""
        target = self.target_fraction(radius_estimate_px)
        if self._fraction is None:
            return target
        step = self.config.max_step
        return min(self._fraction + step, max(self._fraction - step, target))

    def level(self, background: float, peak: float, noise_sigma: float, fraction: float,
              floor_above: float | None = None) -> float:
        """The grey level for a share, never below the floor. The floor stands above the background
        or above ``floor_above`` if brighter: a window's brightest side, where light falls off across it."""
        base = background if floor_above is None else max(background, floor_above)
        return max(self.floor(base, noise_sigma), background + fraction * (peak - background))

    def floor(self, background: float, noise_sigma: float) -> float:
        """The lowest threshold: this far above the background, against over-detection."""
        c = self.config
        return background + max(c.floor_grey, c.floor_noise_sigmas * noise_sigma)

    def update(self, radius_px: float | None) -> None:
        """Advance the state after a frame: towards the size's share, or down when lost."""
        c = self.config
        if radius_px is None:
            current = c.fraction_at_reference if self._fraction is None else self._fraction
            self._fraction = max(c.fraction_far, current - c.max_step)
            return
        self._fraction = self.fraction_for(radius_px)
