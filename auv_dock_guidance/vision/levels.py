"""Robust statistics: of 8-bit pixels from their histogram (exact, and far cheaper than sorting
them), and the median of a few values without np.median's overhead."""

from __future__ import annotations

import numpy as np

_LEVELS = np.arange(256)


def pixel_median(values: np.ndarray) -> float:
    """Median of 8-bit values, exactly as ``np.median`` gives it (the mean of the two middle
    values for an even count)."""
    return _weighted_median(_LEVELS, np.bincount(values.ravel(), minlength=256))


def median_and_mad(values: np.ndarray) -> tuple[float, float]:
    """Median of 8-bit values and their median absolute deviation from it, as ``np.median``
    gives them."""
    counts = np.bincount(values.ravel(), minlength=256)
    middle = _weighted_median(_LEVELS, counts)
    deviation = np.abs(_LEVELS - middle)
    order = np.argsort(deviation, kind="stable")
    return middle, _weighted_median(deviation[order], counts[order])


def _weighted_median(sorted_values: np.ndarray, counts: np.ndarray) -> float:
    """Median of ``sorted_values`` each repeated ``counts`` times."""
    total = int(counts.sum())
    cumulative = np.cumsum(counts)
    low = sorted_values[np.searchsorted(cumulative, (total - 1) // 2, side="right")]
    high = sorted_values[np.searchsorted(cumulative, total // 2, side="right")]
    return 0.5 * (float(low) + float(high))


def median(values: np.ndarray) -> float:
    """np.median of a short array of finite values, the same number without its overhead."""
    ordered = np.sort(values)
    mid = len(ordered) // 2
    return float(ordered[mid]) if len(ordered) % 2 else float((ordered[mid - 1] + ordered[mid]) / 2)


def detrended_deviation(sides: list[np.ndarray]) -> float:
    """Median absolute deviation of a window's border sides (8-bit) about a straight line along
    each: light falling off with depth across a large window is not noise, texture is.

    Each side's line runs through the medians of its two halves (robust to a light crossing it).
    """
    residuals = []
    for side in sides:
        n = len(side)
        if n < 4:
            continue
        half = n // 2
        first, second = pixel_median(side[:half]), pixel_median(side[half:])
        line = first + (second - first) * (np.arange(n) - (half - 1) / 2.0) / (n / 2.0)
        residuals.append(side.astype(np.float64) - line)
    if not residuals:
        return 0.0
    values = np.concatenate(residuals)
    return float(np.median(np.abs(values - np.median(values))))
