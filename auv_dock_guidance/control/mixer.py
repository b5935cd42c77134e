"""From surge, yaw and pitch demands to four thruster PWM pulse widths.

The allocation matrix maps demands (columns: surge, yaw, pitch; each in [-1, 1]) to
thruster commands (rows). Saturation keeps attitude authority: the yaw and pitch part is
fitted first (scaled down only if it alone exceeds a thruster's range), then surge gets
whatever headroom is left. A docking vehicle must keep steering even at full speed.

Commands become pulse widths around a neutral value; small commands jump the ESC's
deadband so they still turn the propeller, reversed thrusters are flipped, and NaN or
out-of-range values can never produce anything but a pulse inside [pwm_min, pwm_max].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from auv_dock_guidance.errors import ConfigError

DOF_NAMES = ("surge", "yaw", "pitch")
# Four stern thrusters: port/starboard x upper/lower. A forward push on the port side
# turns the nose to starboard (positive yaw); a push below the centre line lifts the nose
# (positive pitch = nose up).
DEFAULT_ALLOCATION = (
    (1.0, 1.0, -1.0),  # port upper
    (1.0, -1.0, -1.0),  # starboard upper
    (1.0, 1.0, 1.0),  # port lower
    (1.0, -1.0, 1.0),  # starboard lower
)
DEFAULT_NAMES = ("port_upper", "starboard_upper", "port_lower", "starboard_lower")


@dataclass(frozen=True)
class PwmConfig:
    pwm_min_us: int = 1100
    pwm_neutral_us: int = 1500
    pwm_max_us: int = 1900
    deadband_us: int = 25  # ESC does not spin within neutral +- this
    reversed: tuple[bool, bool, bool, bool] = (False, False, False, False)

    def __post_init__(self) -> None:
        if not self.pwm_min_us < self.pwm_neutral_us < self.pwm_max_us:
            raise ConfigError(
                f"need pwm_min_us < pwm_neutral_us < pwm_max_us, got {self.pwm_min_us}, "
                f"{self.pwm_neutral_us}, {self.pwm_max_us}"
            )
        span = min(self.pwm_neutral_us - self.pwm_min_us, self.pwm_max_us - self.pwm_neutral_us)
        if not 0 <= self.deadband_us < span:
            raise ConfigError(f"deadband_us {self.deadband_us} must be in [0, {span})")
        if len(self.reversed) != 4:
            raise ConfigError("reversed needs one flag per thruster (4)")


@dataclass(frozen=True)
class MixerConfig:
    allocation: tuple[tuple[float, float, float], ...] = DEFAULT_ALLOCATION
    names: tuple[str, ...] = DEFAULT_NAMES
    pwm: PwmConfig = field(default_factory=PwmConfig)

    def __post_init__(self) -> None:
        matrix = np.asarray(self.allocation, dtype=float)
        if matrix.shape != (4, 3) or not np.all(np.isfinite(matrix)):
            raise ConfigError(
                f"allocation must be 4 rows (thrusters) x 3 columns (surge, yaw, pitch), got {matrix.shape}")
        if np.any(np.abs(matrix) > 1.0):
            raise ConfigError("allocation entries must be within [-1, 1]")
        if len(self.names) != 4:
            raise ConfigError("names needs one name per thruster (4)")

    @classmethod
    def from_yaml(cls, path: str | Path) -> MixerConfig:
        """Read `thrusters:` from a YAML file such as config/thrusters.yaml."""
        path = Path(path)
        try:
            data = yaml.safe_load(path.read_text())
        except (OSError, yaml.YAMLError) as exc:
            raise ConfigError(f"{path}: cannot read thruster configuration ({exc})") from exc
        try:
            block = data["thrusters"]
            names = tuple(str(t["name"]) for t in block)
            allocation = tuple(tuple(float(t[d]) for d in DOF_NAMES) for t in block)
            reversed_flags = tuple(bool(t.get("reversed", False)) for t in block)
            pwm_block = data.get("pwm", {})
            pwm = PwmConfig(reversed=reversed_flags, **{k: int(v) for k, v in pwm_block.items()})  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"{path}: malformed thruster configuration ({exc!r})") from exc
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from exc
        return cls(allocation=allocation, names=names, pwm=pwm)  # type: ignore[arg-type]


@dataclass(frozen=True)
class ThrusterCommand:
    """Pulse widths for the four thrusters, in allocation order."""

    pwm_us: tuple[int, int, int, int]
    thrust: tuple[float, float, float, float]  # normalized commands before PWM, [-1, 1]


class Mixer:
    def __init__(self, config: MixerConfig = MixerConfig()) -> None:
        self.config = config
        self._matrix = np.asarray(config.allocation, dtype=float)

    def neutral(self) -> ThrusterCommand:
        n = self.config.pwm.pwm_neutral_us
        return ThrusterCommand((n, n, n, n), (0.0, 0.0, 0.0, 0.0))

    def mix(self, surge: float, yaw: float, pitch: float) -> ThrusterCommand:
        """Thruster commands for normalized demands; NaN demands count as zero."""
        surge, yaw, pitch = (0.0 if not math.isfinite(x) else max(-1.0, min(1.0, x)) for x in (surge, yaw, pitch))
        attitude = self._matrix[:, 1] * yaw + self._matrix[:, 2] * pitch
        peak = float(np.max(np.abs(attitude)))
        if peak > 1.0:
            attitude = attitude / peak
        surge = self._surge_within_headroom(attitude, surge)
        thrust = np.clip(attitude + self._matrix[:, 0] * surge, -1.0, 1.0)
        values = tuple(float(t) for t in thrust)
        return ThrusterCommand(tuple(self.to_pwm(i, t) for i, t in enumerate(values)), values)  # type: ignore[arg-type]

    def _surge_within_headroom(self, attitude: np.ndarray, surge: float) -> float:
        low, high = -math.inf, math.inf
        for a, b in zip(attitude, self._matrix[:, 0], strict=True):
            if b > 0:
                low, high = max(low, (-1 - a) / b), min(high, (1 - a) / b)
            elif b < 0:
                low, high = max(low, (1 - a) / b), min(high, (-1 - a) / b)
        if low > high:
            return 0.0
        return max(low, min(high, surge))

    def to_pwm(self, index: int, thrust: float) -> int:
        """One normalized command as a pulse width, always inside [pwm_min, pwm_max]."""
        p = self.config.pwm
        if not math.isfinite(thrust) or abs(thrust) < 1e-3:
            return p.pwm_neutral_us
        if p.reversed[index]:
            thrust = -thrust
        thrust = max(-1.0, min(1.0, thrust))
        if thrust > 0:
            span = p.pwm_max_us - p.pwm_neutral_us - p.deadband_us
            pwm = p.pwm_neutral_us + p.deadband_us + thrust * span
        else:
            span = p.pwm_neutral_us - p.pwm_min_us - p.deadband_us
            pwm = p.pwm_neutral_us - p.deadband_us + thrust * span
        return int(round(max(p.pwm_min_us, min(p.pwm_max_us, pwm))))
