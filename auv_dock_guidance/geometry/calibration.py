"""Zhang's chessboard calibration (the paper's Table 2), with the checks a person needs.

Inner corners are found and refined to sub-pixel accuracy; views where the board is not
found are reported; OpenCV's calibration (plumb_bob: k1, k2, p1, p2, k3) runs once,
views whose reprojection error is an outlier are dropped with their error as the
reason, and it runs again. The result carries the intrinsics' standard deviations and
a coverage hint when the boards never reached the image corners, where distortion is
strongest and least constrained.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.geometry.camera import CameraModel


class CalibrationError(DockGuidanceError, ValueError):
    """The images cannot give a calibration (too few boards, mixed sizes, ...)."""


MIN_VIEWS = 3
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)


@dataclass(frozen=True)
class Board:
    """A chessboard by its inner corners (columns x rows) and square size in metres."""

    columns: int
    rows: int
    square_m: float

    def __post_init__(self) -> None:
        if self.columns < 3 or self.rows < 3:
            raise CalibrationError(f"board {self.columns}x{self.rows}: need at least 3x3 inner corners")
        if not self.square_m > 0:
            raise CalibrationError(f"square size {self.square_m} m must be positive")

    @classmethod
    def parse(cls, text: str, square_m: float) -> Board:
        try:
            columns, rows = (int(x) for x in text.lower().split("x"))
        except ValueError:
            raise CalibrationError(f"board {text!r} is not COLSxROWS, e.g. 9x6 (inner corners)") from None
        return cls(columns, rows, square_m)

    def object_points(self) -> np.ndarray:
        grid = np.zeros((self.rows * self.columns, 3), np.float32)
        grid[:, :2] = np.mgrid[0 : self.columns, 0 : self.rows].T.reshape(-1, 2) * self.square_m
        return grid


@dataclass(frozen=True)
class ViewResult:
    name: str
    error_px: float | None = None  # RMS reprojection error of this view
    reason: str | None = None  # why it was not used


@dataclass
class CalibrationResult:
    camera: CameraModel
    rms_px: float
    used: list[ViewResult]
    rejected: list[ViewResult]
    std_fx: float
    std_fy: float
    std_cx: float
    std_cy: float
    std_distortion: tuple[float, ...]
    coverage_hint: str | None = None
    corner_coverage: dict[str, bool] = field(default_factory=dict)


def find_corners(gray: np.ndarray, board: Board) -> np.ndarray | None:
    """Sub-pixel inner corners (N, 1, 2) float32, or None when the board is not found."""
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(gray, (board.columns, board.rows), flags=flags)
    if not found:
        return None
    refined = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), _SUBPIX_CRITERIA)
    return refined.reshape(-1, 1, 2)  # OpenCV 5 returns (N, 2), 4.x (N, 1, 2)


def calibrate(
    views: list[tuple[str, np.ndarray]],
    board: Board,
    fix_tangential: bool = False,
    camera_name: str = "camera",
    outlier_factor: float = 3.0,
) -> CalibrationResult:
    """Calibrate from (name, image) pairs. Raises CalibrationError with the reason when impossible."""
    if not views:
        raise CalibrationError("no images given")
    sizes = {name: image.shape[:2] for name, image in views}
    first_size = next(iter(sizes.values()))
    odd = [f"{n} ({s[1]}x{s[0]})" for n, s in sizes.items() if s != first_size]
    if odd:
        raise CalibrationError(
            f"images differ in size: expected {first_size[1]}x{first_size[0]} like {views[0][0]}, got " + ", ".join(odd)
        )
    height, width = first_size
    found: list[tuple[str, np.ndarray]] = []
    rejected: list[ViewResult] = []
    for name, image in views:
        gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        corners = find_corners(gray, board)
        if corners is None:
            rejected.append(ViewResult(name, reason=f"no {board.columns}x{board.rows} board found"))
        else:
            found.append((name, corners))
    if not found:
        raise CalibrationError(f"no {board.columns}x{board.rows} board found in any of {len(views)} images")
    while True:
        if len(found) < MIN_VIEWS:
            raise CalibrationError(
                f"only {len(found)} usable view(s), need at least {MIN_VIEWS}; rejected: "
                + "; ".join(f"{r.name}: {r.reason}" for r in rejected)
            )
        solution = _solve(found, board, (width, height), fix_tangential)
        errors = solution["per_view"]
        limit = max(outlier_factor * float(np.median(errors)), 0.5)
        worst = int(np.argmax(errors))
        if errors[worst] <= limit or len(found) <= MIN_VIEWS:
            break
        name = found[worst][0]
        rejected.append(ViewResult(name, float(errors[worst]), f"outlier: {errors[worst]:.2f} px RMS > {limit:.2f} px"))
        del found[worst]
    k, d, std = solution["matrix"], solution["distortion"], solution["std"]
    d = np.zeros(5) if d is None else np.asarray(d, dtype=float).ravel()
    camera = CameraModel.from_camera_info(width, height, k.ravel(), d[:5], "plumb_bob", name=camera_name)
    coverage = _corner_coverage([c for _, c in found], width, height)
    missing = [corner for corner, ok in coverage.items() if not ok]
    hint = None
    if missing:
        hint = ("no board reached the " + ", ".join(missing) + " corner(s) of the image: add views with the board "
                "there, where distortion is strongest")
    return CalibrationResult(
        camera=camera,
        rms_px=float(solution["rms"]),
        used=[ViewResult(n, float(e)) for (n, _), e in zip(found, errors, strict=True)],
        rejected=rejected,
        std_fx=float(std[0]),
        std_fy=float(std[1]),
        std_cx=float(std[2]),
        std_cy=float(std[3]),
        std_distortion=tuple(float(x) for x in std[4:9]),
        coverage_hint=hint,
        corner_coverage=coverage,
    )


def _solve(found: list[tuple[str, np.ndarray]], board: Board, size: tuple[int, int], fix_tangential: bool) -> dict:
    object_points = [board.object_points() for _ in found]
    image_points = [c for _, c in found]
    flags = cv2.CALIB_FIX_TANGENT_DIST if fix_tangential else 0
    rms, k, d, _, _, std_intrinsics, _, per_view = cv2.calibrateCameraExtended(  # type: ignore[call-overload]
        object_points, image_points, size, None, None, flags=flags  # no initial guess: None, which the stubs omit
    )
    return {
        "rms": rms,
        "matrix": k,
        "distortion": d,
        "std": np.asarray(std_intrinsics, dtype=float).ravel(),
        "per_view": np.asarray(per_view, dtype=float).ravel(),
    }


def _corner_coverage(corner_sets: list[np.ndarray], width: int, height: int, share: float = 0.2) -> dict[str, bool]:
    """Whether any detected corner lies in each image corner region (outer 20 % of each side)."""
    points = np.concatenate([c.reshape(-1, 2) for c in corner_sets])
    left, right = points[:, 0] < share * width, points[:, 0] > (1 - share) * width
    top, bottom = points[:, 1] < share * height, points[:, 1] > (1 - share) * height
    return {
        "top-left": bool(np.any(left & top)),
        "top-right": bool(np.any(right & top)),
        "bottom-left": bool(np.any(left & bottom)),
        "bottom-right": bool(np.any(right & bottom)),
    }


def undistort_image(image: np.ndarray, camera: CameraModel) -> np.ndarray:
    """The image as an ideal pinhole camera with the same K would see it.

    Output pixels whose ray lies beyond the lens model's fold have no valid source and are
    left black rather than filled with folded-over content.
    """
    h, w = image.shape[:2]
    if (w, h) != (camera.width, camera.height):
        raise CalibrationError(f"image is {w}x{h} but the camera model is {camera.width}x{camera.height}")
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    xy = np.stack([(xs - camera.cx) / camera.fx, (ys - camera.cy) / camera.fy], axis=-1)
    source = camera.normalized_to_pixels(xy).astype(np.float32)
    valid = camera.normalized_valid(xy)
    source[~valid] = -1.0
    return cv2.remap(image, source[..., 0], source[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
