"""Pinhole camera with plumb_bob (radial + tangential) distortion.

Loaded from the camera_info YAML that ROS ``camera_calibration`` writes, or from the
fields of a ``sensor_msgs/CameraInfo``. Points move between three spaces:

* pixels: the image as recorded (distorted);
* normalized: the ideal image plane at z = 1 in the camera optical frame
  (x right, y down, z forward);
* camera: 3-D points in metres in the optical frame.

Undistortion is solved with Newton's method and then checked by re-distorting. Strong
radial models fold over (r * (1 + k1 r^2 + k2 r^4 + k3 r^6) stops increasing); pixels
beyond the fold have no valid undistortion and are flagged instead of returning garbage.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from auv_dock_guidance.errors import CameraModelError

log = logging.getLogger(__name__)

_FOLD_SEARCH_MAX = 4.0  # normalized radius up to which a fold of the radial model is looked for
_ROUND_TRIP_TOL_PX = 0.05


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics and plumb_bob distortion of one camera at one resolution."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0
    name: str = "camera"
    frame_id: str = "camera_optical_frame"
    approximate: bool = False  # no calibration: focal length guessed, principal point at the centre

    def __post_init__(self) -> None:
        for field_name in ("width", "height"):
            value = getattr(self, field_name)
            if not isinstance(value, (int, np.integer)) or value <= 0:
                raise CameraModelError(f"{field_name} {value!r} is not a positive integer")
        for field_name in ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"):
            value = getattr(self, field_name)
            if not math.isfinite(value):
                raise CameraModelError(f"{field_name} {value!r} is not a finite number")
        if self.fx <= 0 or self.fy <= 0:
            raise CameraModelError(f"focal lengths fx={self.fx}, fy={self.fy} must be positive")

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_camera_info(
        cls,
        width: int,
        height: int,
        k: Any,
        d: Any,
        distortion_model: str = "plumb_bob",
        name: str = "camera",
        frame_id: str = "camera_optical_frame",
        source: str = "camera_info",
    ) -> CameraModel:
        """Build from the fields of a sensor_msgs/CameraInfo (k: 9 values row-major, d: 0-5).

        Refused (CameraModelError) where the lens model has no valid undistortion over most of
        the image; other implausible values (see ``plausibility_warnings``) are logged once,
        naming ``source``.
        """
        k_values = np.asarray(k, dtype=float).ravel()
        if k_values.size != 9:
            raise CameraModelError(f"camera matrix has {k_values.size} values, expected 9")
        d_values = [float(x) for x in np.asarray(d, dtype=float).ravel()]
        if distortion_model not in ("plumb_bob", "rational_polynomial", "") and d_values:
            raise CameraModelError(
                f"distortion model {distortion_model!r} is not supported (use plumb_bob)"
            )
        if distortion_model == "rational_polynomial" and any(abs(x) > 0 for x in d_values[5:]):
            raise CameraModelError("rational_polynomial with k4..k6 != 0 is not supported")
        if len(d_values) not in (0, 4, 5, 8):
            raise CameraModelError(f"distortion has {len(d_values)} values, expected 0, 4 or 5")
        d_values = (d_values + [0.0] * 5)[:5]
        model = cls(
            width=int(width),
            height=int(height),
            fx=float(k_values[0]),
            fy=float(k_values[4]),
            cx=float(k_values[2]),
            cy=float(k_values[5]),
            k1=d_values[0],
            k2=d_values[1],
            p1=d_values[2],
            p2=d_values[3],
            k3=d_values[4],
            name=name,
            frame_id=frame_id,
        )
        refusal, warnings = _plausibility(model)
        if refusal:
            raise CameraModelError(refusal)
        _log_once(model, source, warnings)
        return model

    @classmethod
    def from_yaml(cls, path: str | Path) -> CameraModel:
        """Read a ROS camera_info YAML (camera_calibration_parsers format)."""
        path = Path(path)
        try:
            data = yaml.safe_load(path.read_text())
        except OSError as exc:
            raise CameraModelError(f"{path}: cannot read ({exc.strerror})") from exc
        except yaml.YAMLError as exc:
            raise CameraModelError(f"{path}: not valid YAML ({exc})") from exc
        if not isinstance(data, dict):
            raise CameraModelError(f"{path}: expected a mapping with image_width, camera_matrix, ...")
        try:
            return cls.from_camera_info(
                width=_require_int(data, "image_width", path),
                height=_require_int(data, "image_height", path),
                k=_matrix_data(data, "camera_matrix", path),
                d=_matrix_data(data, "distortion_coefficients", path),
                distortion_model=str(data.get("distortion_model", "plumb_bob")),
                name=str(data.get("camera_name", "camera")),
                source=str(path),
            )
        except CameraModelError as exc:
            if str(exc).startswith(str(path)):
                raise
            raise CameraModelError(f"{path}: {exc}") from exc

    def to_yaml_dict(self) -> dict[str, Any]:
        """The camera_info YAML mapping (as camera_calibration_parsers writes it)."""
        k = [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0]
        p = [self.fx, 0.0, self.cx, 0.0, 0.0, self.fy, self.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        return {
            "image_width": self.width,
            "image_height": self.height,
            "camera_name": self.name,
            "camera_matrix": {"rows": 3, "cols": 3, "data": k},
            "distortion_model": "plumb_bob",
            "distortion_coefficients": {"rows": 1, "cols": 5, "data": list(self.distortion)},
            "rectification_matrix": {
                "rows": 3,
                "cols": 3,
                "data": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            },
            "projection_matrix": {"rows": 3, "cols": 4, "data": p},
        }

    def scaled(self, factor: float) -> CameraModel:
        """The same lens at another resolution (intrinsics scale, distortion does not)."""
        if factor <= 0:
            raise CameraModelError(f"scale factor {factor} must be positive")
        return replace(
            self,
            width=max(1, round(self.width * factor)),
            height=max(1, round(self.height * factor)),
            fx=self.fx * factor,
            fy=self.fy * factor,
            cx=(self.cx + 0.5) * factor - 0.5,
            cy=(self.cy + 0.5) * factor - 0.5,
        )

    def for_image(self, width: int, height: int) -> CameraModel:
        """This camera for images of the given size: itself, or scaled when the images were
        resized or binned uniformly from the calibrated size (within a pixel of rounding).

        Raises CameraModelError for any other size: a crop or another camera needs its own
        calibration, and a guess would bias every range and bearing.
        """
        if (width, height) == (self.width, self.height):
            return self
        if self.approximate:  # nothing was calibrated at this size: keep the field of view
            return approximate_camera(width, height, focal_px=self.fx * width / self.width)
        factor = width / self.width
        if width <= 0 or height <= 0 or abs(self.height * factor - height) > 1.0:
            raise CameraModelError(
                f"images are {width}x{height} but the camera model is {self.width}x{self.height}, "
                "and they are not a uniform resize of each other: give the camera_info of these images"
            )
        return replace(self.scaled(factor), width=width, height=height)

    # ----------------------------------------------------------------- properties
    @property
    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion(self) -> tuple[float, float, float, float, float]:
        return (self.k1, self.k2, self.p1, self.p2, self.k3)

    @property
    def focal_px(self) -> float:
        """Mean focal length in pixels: the f of z = f * R / r."""
        return 0.5 * (self.fx + self.fy)

    @property
    def fold_radius(self) -> float | None:
        """Normalized undistorted radius where the radial model stops increasing, if any."""
        return _radial_fold(self.k1, self.k2, self.k3)

    # ----------------------------------------------------------------- mappings
    def distort_normalized(self, xy: np.ndarray) -> np.ndarray:
        """Ideal normalized coordinates (N, 2) -> distorted normalized coordinates."""
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        xd = x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x)
        yd = y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y
        return np.stack([xd, yd], axis=-1)

    def normalized_to_pixels(self, xy: np.ndarray) -> np.ndarray:
        """Ideal normalized coordinates -> distorted pixel coordinates."""
        xy = np.asarray(xy, dtype=float)
        d = self.distort_normalized(xy)
        return np.stack([self.fx * d[..., 0] + self.cx, self.fy * d[..., 1] + self.cy], axis=-1)

    def normalized_valid(self, xy: np.ndarray) -> np.ndarray:
        """True where a normalized point lies inside the fold (its projection is one-to-one)."""
        fold = self.fold_radius
        xy = np.asarray(xy, dtype=float)
        if fold is None:
            return np.ones(xy.shape[:-1], dtype=bool)
        return np.hypot(xy[..., 0], xy[..., 1]) < fold

    def project(self, points_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """3-D points in the optical frame (N, 3) -> (pixels (N, 2), valid (N,)).

        A point is valid when it is in front of the camera and inside the lens model's fold.
        """
        pts = np.asarray(points_cam, dtype=float)
        z = pts[..., 2]
        in_front = z > 1e-6
        safe_z = np.where(in_front, z, 1.0)
        xy = pts[..., :2] / safe_z[..., None]
        return self.normalized_to_pixels(xy), in_front & self.normalized_valid(xy)

    def pixels_to_normalized(self, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distorted pixels (N, 2) -> (ideal normalized coordinates (N, 2), valid (N,)).

        Newton iterations on the full plumb_bob model, started from OpenCV's approximate
        undistortion (a step or two then suffice); points that do not come out valid start
        again from the distorted point. A result is valid only when it lies inside the fold
        and re-distorts to the input within 0.05 px; anything else (for example image
        corners beyond the fold) is flagged, never silently returned as if it were right.
        """
        pix = np.asarray(pixels, dtype=float)
        target = np.stack([(pix[..., 0] - self.cx) / self.fx, (pix[..., 1] - self.cy) / self.fy], -1)
        flat = pix.reshape(-1, 1, 2)
        start = target.copy()
        if flat.shape[0]:
            guess = cv2.undistortPoints(flat, self.matrix, np.array(self.distortion)).reshape(target.shape)
            start = np.where(np.isfinite(guess), guess, target)
        xy, converged = self._newton(target, start, iterations=4)
        valid = converged & self._round_trip(xy, pix)
        if not valid.all():  # where the quick start led astray: from the distorted point, as always
            retry = ~valid
            xy[retry] = self._newton(target[retry], target[retry].copy())[0]
            valid[retry] = self._round_trip(xy[retry], pix[retry])
        return xy, valid

    def _newton(self, target: np.ndarray, xy: np.ndarray, iterations: int = 20) -> tuple[np.ndarray, np.ndarray]:
        """Normalized points that distort to ``target``, iterated from ``xy``, and which converged."""
        norm = np.full(target.shape[:-1], np.inf)
        for _ in range(iterations):
            residual = self.distort_normalized(xy) - target
            j = self._distortion_jacobian(xy)
            det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
            det = np.where(np.abs(det) < 1e-12, 1e-12, det)
            dx = (j[..., 1, 1] * residual[..., 0] - j[..., 0, 1] * residual[..., 1]) / det
            dy = (-j[..., 1, 0] * residual[..., 0] + j[..., 0, 0] * residual[..., 1]) / det
            step = np.stack([dx, dy], -1)
            # Damp large steps so a point near the fold does not jump across it.
            norm = np.hypot(step[..., 0], step[..., 1])
            step *= np.minimum(1.0, 0.25 / np.maximum(norm, 1e-12))[..., None]
            xy = xy - step
            if float(np.max(norm, initial=0.0)) < 1e-10:
                break
        return xy, norm < 1e-10

    def _round_trip(self, xy: np.ndarray, pix: np.ndarray) -> np.ndarray:
        """Inside the fold and back on the input pixel within tolerance."""
        back = self.normalized_to_pixels(xy)
        error_px = np.hypot(back[..., 0] - pix[..., 0], back[..., 1] - pix[..., 1])
        return np.isfinite(error_px) & (error_px < _ROUND_TRIP_TOL_PX) & self.normalized_valid(xy)

    def _distortion_jacobian(self, xy: np.ndarray) -> np.ndarray:
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        dradial_dr2 = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3)
        j = np.empty((*xy.shape[:-1], 2, 2))
        j[..., 0, 0] = radial + 2 * x * x * dradial_dr2 + 2 * self.p1 * y + 6 * self.p2 * x
        j[..., 0, 1] = 2 * x * y * dradial_dr2 + 2 * self.p1 * x + 2 * self.p2 * y
        j[..., 1, 0] = 2 * x * y * dradial_dr2 + 2 * self.p1 * x + 2 * self.p2 * y
        j[..., 1, 1] = radial + 2 * y * y * dradial_dr2 + 6 * self.p1 * y + 2 * self.p2 * x
        return j


@lru_cache(maxsize=64)  # asked at every undistortion; a polynomial's roots cost more than the rest of it
def _radial_fold(k1: float, k2: float, k3: float) -> float | None:
    """Smallest r > 0 where d/dr [r (1 + k1 r^2 + k2 r^4 + k3 r^6)] = 0, if below the search limit.

    The derivative is 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 with s = r^2.
    """
    roots = np.roots([7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0]) if (k1 or k2 or k3) else np.array([])
    positive = [
        math.sqrt(r.real)
        for r in roots
        if abs(r.imag) < 1e-12 and r.real > 0 and math.sqrt(r.real) < _FOLD_SEARCH_MAX
    ]
    return min(positive) if positive else None


# A lens model must undistort most of its image: the paper's Table 2 lens folds over in the
# image corners (9 % of the image), which is what extrapolating the polynomial past the
# calibrated boards gives; beyond a quarter something is wrong, beyond half nothing usable is left.
_WARN_UNUSABLE_SHARE = 0.25
_REFUSE_UNUSABLE_SHARE = 0.5
# Distortion that scales the radius of an image point by more than 2 or less than 0.5 is
# beyond what a lens the plumb_bob model suits can do (a 120 deg wide-angle stays within this).
_PLAUSIBLE_RADIAL_SCALE = (0.5, 2.0)
_CHECK_GRID = 33  # points per image side at which the lens model is checked


def plausibility_warnings(camera: CameraModel) -> list[str]:
    """What is implausible about this calibration, each naming the value and the limit.

    Raises CameraModelError where the lens model has no valid undistortion over most of the
    image (it folds over, or its inverse does not converge): no use of it could be right.
    """
    refusal, warnings = _plausibility(camera)
    if refusal:
        raise CameraModelError(refusal)
    return list(warnings)


@lru_cache(maxsize=16)  # camera_info arrives with every frame: check each distinct model once
def _plausibility(camera: CameraModel) -> tuple[str | None, tuple[str, ...]]:
    warnings = []
    for axis, value, size in (("cx", camera.cx, camera.width), ("cy", camera.cy, camera.height)):
        if not -0.5 <= value <= size - 0.5:
            warnings.append(f"principal point {axis} {value:g} px lies outside the image (0-{size - 1} px)")
    distortion = "distortion " + ", ".join(
        f"{name} {value:g}" for name, value in zip(("k1", "k2", "p1", "p2", "k3"), camera.distortion, strict=True)
    )
    side = np.linspace(0.0, 1.0, _CHECK_GRID)
    grid = np.stack(np.meshgrid(side * (camera.width - 1), side * (camera.height - 1)), axis=-1).reshape(-1, 2)
    xy, valid = camera.pixels_to_normalized(grid)
    unusable = 1.0 - float(np.mean(valid))
    if unusable > _REFUSE_UNUSABLE_SHARE:
        where = "the whole image" if unusable == 1.0 else f"{100 * unusable:.0f} % of the image"
        reason = f"{distortion} has no valid undistortion over {where} (the lens model folds over)"
        return "; ".join([*warnings, reason]), ()
    if unusable > _WARN_UNUSABLE_SHARE:
        warnings.append(f"{distortion} has no valid undistortion over {100 * unusable:.0f} % of the image "
                        f"(more than {100 * _WARN_UNUSABLE_SHARE:.0f} %)")
    ideal_radius = np.hypot(xy[valid, 0], xy[valid, 1])
    distorted_radius = np.hypot(*(camera.distort_normalized(xy[valid]).T))
    away = ideal_radius > 1e-3
    if np.any(away):
        scale = distorted_radius[away] / ideal_radius[away]
        low, high = _PLAUSIBLE_RADIAL_SCALE
        extreme = float(scale[np.argmax(np.abs(np.log(np.maximum(scale, 1e-12))))])
        if not low <= extreme <= high:
            warnings.append(f"{distortion} scales image radii by {extreme:.3g} "
                            f"(a real lens stays within {low:g}-{high:g})")
    return None, tuple(warnings)


_logged: set[tuple[CameraModel, str]] = set()


def _log_once(camera: CameraModel, source: str, warnings: tuple[str, ...]) -> None:
    if warnings and (camera, source) not in _logged:
        _logged.add((camera, source))
        for warning in warnings:
            log.warning("%s: implausible calibration: %s", source, warning)


def _require_int(data: dict[str, Any], key: str, path: Path) -> int:
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise CameraModelError(f"{path}: {key} {value!r} is not a positive integer")
    return value


def _matrix_data(data: dict[str, Any], key: str, path: Path) -> list[float]:
    block = data.get(key)
    if not isinstance(block, dict) or "data" not in block:
        raise CameraModelError(f"{path}: {key} is missing or has no 'data' list")
    values = block["data"]
    if not isinstance(values, list):
        raise CameraModelError(f"{path}: {key}.data is not a list")
    try:
        floats = [float(v) for v in values]
    except (TypeError, ValueError) as exc:
        raise CameraModelError(f"{path}: {key}.data holds a non-number ({exc})") from exc
    if not all(math.isfinite(v) for v in floats):
        raise CameraModelError(f"{path}: {key}.data holds NaN or infinity")
    return floats


@dataclass(frozen=True)
class ApproximateLens:
    """What a user knows of an uncalibrated camera: its focal length in pixels of the frames
    it recorded, or its horizontal field of view. The frames' size completes the camera."""

    focal_px: float | None = None
    hfov_deg: float | None = None

    def __post_init__(self) -> None:
        if (self.focal_px is None) == (self.hfov_deg is None):
            raise CameraModelError("an approximate camera needs either a focal length or a field of view")
        if self.focal_px is not None and not (math.isfinite(self.focal_px) and self.focal_px > 0):
            raise CameraModelError(f"focal length {self.focal_px} px must be a positive number")
        if self.hfov_deg is not None and not (math.isfinite(self.hfov_deg) and 1.0 <= self.hfov_deg <= 170.0):
            raise CameraModelError(f"horizontal field of view {self.hfov_deg} deg must be from 1 to 170")

    def camera_for(self, width: int, height: int) -> CameraModel:
        return approximate_camera(width, height, self.focal_px, self.hfov_deg)


def approximate_camera(width: int, height: int, focal_px: float | None = None,
                       hfov_deg: float | None = None) -> CameraModel:
    """A camera without calibration (``approximate``): square pixels of focal length ``focal_px``,
    or the one that gives ``hfov_deg`` across the width; principal point at the centre; no
    distortion. Bearings are about right near the centre; ranges scale with the focal length."""
    if hfov_deg is not None:
        focal_px = 0.5 * width / math.tan(math.radians(hfov_deg) / 2.0)
    if focal_px is None:
        raise CameraModelError("an approximate camera needs either a focal length or a field of view")
    return CameraModel(width=width, height=height, fx=focal_px, fy=focal_px, cx=(width - 1) / 2.0,
                       cy=(height - 1) / 2.0, name="approximate", approximate=True)


PAPER_FOCAL_PX = 1734.9  # paper_camera().focal_px: the lens the pixel sizes of our defaults are for


def paper_camera() -> CameraModel:
    """The paper's Table 2 calibration at 1920x1080 (the same as config/camera_info.yaml)."""
    return CameraModel(
        width=1920,
        height=1080,
        fx=1734.7,
        fy=1735.1,
        cx=997.8362,
        cy=583.7621,
        k1=-0.2718,
        k2=-0.4929,
        k3=0.1278,
        name="dock_camera",
    )
