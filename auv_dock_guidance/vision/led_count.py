"""The dock's LED count, learned from the rings the detector assembles, when the user did not give it.

The count is fixed by the dock, but with it unknown each frame's ring is assembled with
whatever count fits that frame best. A ring of another count (an LED lost in a bloom or on a
lit funnel, or a bump on the funnel's outline taken for one) puts its LEDs at the wrong
slots, and the pose fitted to them tilts 15-30 deg off while its scatter claims a few
degrees (measured on simulated open-water episodes; the dock's own count: 1-6 deg). Wrong
counts are mostly too low (LEDs missed, rarely one gained), so the dock's count is the
largest one seen in a fair share of the whole rings so far.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass


@dataclass(frozen=True)
class CountVoteConfig:
    min_rings: int = 10  # whole rings seen before any count is told from the others
    min_share: float = 0.1  # of the whole rings: a count seen less often is a misreading


class LedCountVote:
    """Whole rings vote with their count; ``disputes`` tells a ring of another count than the dock's."""

    def __init__(self, config: CountVoteConfig = CountVoteConfig()) -> None:
        self.config = config
        self._votes: Counter[int] = Counter()

    def reset(self) -> None:
        self._votes.clear()

    def add(self, count: int) -> None:
        self._votes[count] += 1

    @property
    def rings(self) -> int:
        """Whole rings that have voted."""
        return sum(self._votes.values())

    @property
    def count(self) -> int | None:
        """The dock's count as far as the votes tell, or None while too few rings have voted."""
        total = self.rings
        if total < self.config.min_rings:
            return None
        return max((n for n, votes in self._votes.items() if votes >= self.config.min_share * total), default=None)

    def disputes(self, count: int) -> bool:
        settled = self.count
        return settled is not None and count != settled
