"""Zhang's chessboard calibration (the paper's Table 2), with the checks a person needs.

Inner corners are found and refined to sub-pixel accuracy with a window sized to each
image's board; views where the board is not found are reported; OpenCV's calibration
(plumb_bob: k1, k2, p1, p2, k3) runs once, a view whose reprojection error stands out
from the others (a robust rule: median and median absolute deviation) is dropped with
its error as the reason, and it runs again. The result carries the intrinsics' standard
deviations and a coverage hint when the boards never reached the image corners, where
distortion is strongest and least constrained.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from auv_dock_guidance.errors import CameraModelError, DockGuidanceError
from auv_dock_guidance.geometry.camera import CameraModel, plausibility_warnings


class CalibrationError(DockGuidanceError, ValueError):
    """The images cannot give a calibration (too few boards, mixed sizes, ...)."""


MIN_VIEWS = 3
SQUARE_RANGE_M = (1e-5, 10.0)  # a printed square from 10 um (microscope targets) to 10 m
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
# cornerSubPix solves for the point that every image gradient in its window points away
# from, which holds only for the two edges through the corner. The half-window is the
# share below of the board's clearance (how far a window reaches before another edge
# enters it), with a wide margin for what the detected corners do not show: the outer
# squares, foreshortened further or cut by the paper's margin, and blur that widens the
# foreign edges. On the 13 real 640x480 photos of OpenCV's samples refinement broke at
# 0.41 of the clearance (the outermost row of a tilted board); 0.3 keeps every board there.
_WINDOW_SHARE_OF_CLEARANCE = 0.3
_MIN_HALF_WINDOW_PX = 3
_MAX_GRID_BEND = 0.3  # see grid_bend: good boards stay below 0.15, misplaced corners measured 0.47 and more
# A view is an outlier when its error lies beyond the median by this many robust standard
# deviations (1.4826 MAD) and is at least this many times the median: the second guards a
# tight cluster, where a small spread would call an ordinary view an outlier.
_OUTLIER_SIGMAS = 5.0
_OUTLIER_MIN_RATIO = 2.0


@dataclass(frozen=True)
class Board:
    """A chessboard by its inner corners (columns x rows) and square size in metres."""

    columns: int
    rows: int
    square_m: float

    def __post_init__(self) -> None:
        if self.columns < 3 or self.rows < 3:
            raise CalibrationError(f"board {self.columns}x{self.rows}: need at least 3x3 inner corners")
        low, high = SQUARE_RANGE_M
        if not low <= self.square_m <= high:
            raise CalibrationError(
                f"square size {self.square_m:g} m is outside {low:g} m to {high:g} m: "
                "give the side of one printed square in metres, e.g. 0.04"
            )

    @classmethod
    def parse(cls, text: str, square_m: float) -> Board:
        try:
            columns, rows = (int(x) for x in text.lower().split("x"))
        except ValueError:
            raise CalibrationError(f"board {text!r} is not COLSxROWS, e.g. 9x6 (inner corners)") from None
        return cls(columns, rows, square_m)

    def grid_squares(self) -> np.ndarray:
        """Inner corners on the board plane (N, 3) in units of one square, row by row."""
        grid = np.zeros((self.rows * self.columns, 3), np.float32)
        grid[:, :2] = np.mgrid[0 : self.columns, 0 : self.rows].T.reshape(-1, 2)
        return grid

    def object_points(self) -> np.ndarray:
        """Inner corners on the board plane (N, 3) in metres."""
        return self.grid_squares() * np.float32(self.square_m)


@dataclass(frozen=True)
class FoundBoard:
    """One image's refined inner corners and the refinement half-window used for them."""

    name: str
    corners: np.ndarray  # (N, 1, 2) float32, row by row
    half_window_px: int


@dataclass(frozen=True)
class ViewResult:
    name: str
    error_px: float | None = None  # RMS reprojection error of this view
    reason: str | None = None  # why it was not used
    half_window_px: int | None = None  # cornerSubPix half-window used for this view


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
    warnings: list[str] = field(default_factory=list)  # implausible values of the result


def corner_clearance_px(corners: np.ndarray, board: Board) -> float:
    """How far a square window centred on a corner reaches before an edge not through that
    corner enters it: the smallest Chebyshev (max-norm) distance from any inner corner to
    the far sides of the squares it belongs to. Perspective and rotation shrink it below
    the corner spacing (to 0.71 of it for a board turned 45 deg)."""
    grid = np.asarray(corners, dtype=float).reshape(board.rows, board.columns, 2)
    quads = np.stack([grid[:-1, :-1], grid[:-1, 1:], grid[1:, 1:], grid[1:, :-1]], axis=2).reshape(-1, 4, 2)
    distances = []
    for k in range(4):
        corner = quads[:, k]
        a, b, c = quads[:, (k + 1) % 4], quads[:, (k + 2) % 4], quads[:, (k + 3) % 4]
        distances += [_chebyshev_to_segments(corner, a, b), _chebyshev_to_segments(corner, b, c)]
    return float(np.min(distances))


def _chebyshev_to_segments(points: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Max-norm distance from each point to its segment, all (N, 2).

    Along the segment, max(|u_x + t v_x|, |u_y + t v_y|) is convex and piecewise linear in t,
    so its minimum on [0, 1] lies at an end or where the two terms are equal.
    """
    u, v = starts - points, ends - starts
    candidates = [np.zeros(len(points)), np.ones(len(points))]
    with np.errstate(divide="ignore", invalid="ignore"):
        for sign in (1.0, -1.0):
            t = (sign * u[:, 1] - u[:, 0]) / (v[:, 0] - sign * v[:, 1])
            candidates.append(np.clip(np.nan_to_num(t, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0))
    return np.min([np.max(np.abs(u + t[:, None] * v), axis=1) for t in candidates], axis=0)


def refinement_half_window(corners: np.ndarray, board: Board) -> int:
    """The cornerSubPix half-window for this board as the image shows it (see the share above)."""
    return max(_MIN_HALF_WINDOW_PX, int(_WINDOW_SHARE_OF_CLEARANCE * corner_clearance_px(corners, board)))


def grid_bend(corners: np.ndarray, board: Board) -> float:
    """The largest second difference of the corners along a row or column, in units of the
    local corner spacing: about 0.1-0.3 for a real board under perspective and distortion,
    1 or more where a detector put a corner on the wrong square."""
    grid = np.asarray(corners, dtype=float).reshape(board.rows, board.columns, 2)
    worst = 0.0
    for lines in (grid, grid.transpose(1, 0, 2)):
        bend = np.linalg.norm(lines[:, :-2] - 2 * lines[:, 1:-1] + lines[:, 2:], axis=2)
        spacing = np.linalg.norm(lines[:, 2:] - lines[:, :-2], axis=2) / 2
        worst = max(worst, float(np.max(bend / np.maximum(spacing, 1e-9))))
    return worst


def find_corners(gray: np.ndarray, board: Board, name: str = "image") -> FoundBoard | None:
    """Sub-pixel inner corners with the half-window used, or None when the board is not found.

    The classic detector (the one OpenCV's calibration sample uses) goes first; where it
    fails, or puts a corner on the wrong square (it can, on small tilted boards whose
    squares merge when it dilates them), the sector-based detector is asked. Either gives
    the starting corners of the same refinement.
    """
    size = (board.columns, board.rows)
    classic_flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    attempts = (
        lambda: cv2.findChessboardCorners(gray, size, flags=classic_flags),
        lambda: cv2.findChessboardCornersSB(gray, size, flags=cv2.CALIB_CB_NORMALIZE_IMAGE),
    )
    for detect in attempts:
        found, corners = detect()
        if not found:
            continue
        corners = np.ascontiguousarray(corners, dtype=np.float32).reshape(-1, 1, 2)
        half = refinement_half_window(corners, board)
        refined = cv2.cornerSubPix(gray, corners, (half, half), (-1, -1), _SUBPIX_CRITERIA).reshape(-1, 1, 2)
        if grid_bend(refined, board) <= _MAX_GRID_BEND:
            return FoundBoard(name, refined, half)
    return None


def outlier_limit_px(errors: np.ndarray) -> float:
    """The per-view error beyond which a view stands out from the others (see the rule above)."""
    median = float(np.median(errors))
    robust_sigma = 1.4826 * float(np.median(np.abs(errors - median)))
    return max(median + _OUTLIER_SIGMAS * robust_sigma, _OUTLIER_MIN_RATIO * median)


def calibrate(
    views: list[tuple[str, np.ndarray]],
    board: Board,
    fix_tangential: bool = False,
    camera_name: str = "camera",
    skipped: list[ViewResult] | None = None,
) -> CalibrationResult:
    """Calibrate from (name, image) pairs. Raises CalibrationError with the reason when impossible.

    ``skipped`` are inputs the caller could not use (unreadable files), reported with the rest.
    """
    unreadable = list(skipped or [])
    if not views:
        if unreadable:
            raise CalibrationError("none of the images can be used: " + _reasons(unreadable))
        raise CalibrationError("no images given")
    sizes = {name: image.shape[:2] for name, image in views}
    first_size = next(iter(sizes.values()))
    odd = [f"{n} ({s[1]}x{s[0]})" for n, s in sizes.items() if s != first_size]
    if odd:
        raise CalibrationError(
            f"images differ in size: expected {first_size[1]}x{first_size[0]} like {views[0][0]}, got " + ", ".join(odd)
        )
    height, width = first_size
    found: list[FoundBoard] = []
    not_found: list[ViewResult] = []
    for name, image in views:
        gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        board_view = find_corners(gray, board, name)
        if board_view is None:
            not_found.append(ViewResult(name, reason=f"no {board.columns}x{board.rows} board found"))
        else:
            found.append(board_view)
    if not found:
        raise CalibrationError(f"no {board.columns}x{board.rows} board found in any of {len(views)} images"
                               + (f"; unreadable: {_reasons(unreadable)}" if unreadable else ""))
    return calibrate_boards(found, board, (width, height), fix_tangential, camera_name, unreadable + not_found)


def _reasons(views: list[ViewResult]) -> str:
    return "; ".join(f"{v.name}: {v.reason}" for v in views)


def calibrate_boards(
    found: list[FoundBoard],
    board: Board,
    image_size: tuple[int, int],
    fix_tangential: bool = False,
    camera_name: str = "camera",
    already_rejected: list[ViewResult] | None = None,
) -> CalibrationResult:
    """Calibrate from refined corners (width, height given), dropping outlier views one at a time."""
    width, height = image_size
    found = list(found)
    rejected = list(already_rejected or [])
    while True:
        if len(found) < MIN_VIEWS:
            raise CalibrationError(
                f"only {len(found)} usable view(s), need at least {MIN_VIEWS}; rejected: " + _reasons(rejected)
            )
        solution = _solve([f.corners for f in found], board, (width, height), fix_tangential)
        errors = solution["per_view"]
        limit = outlier_limit_px(errors)
        worst = int(np.argmax(errors))
        if errors[worst] <= limit or len(found) <= MIN_VIEWS:
            break
        odd = found.pop(worst)
        reason = (f"outlier: {errors[worst]:.2f} px RMS, median of all views {np.median(errors):.2f} px "
                  f"(limit {limit:.2f} px)")
        rejected.append(ViewResult(odd.name, float(errors[worst]), reason, odd.half_window_px))
    k, d, std = solution["matrix"], solution["distortion"], solution["std"]
    k1, k2, p1, p2, k3 = (float(x) for x in (np.zeros(5) if d is None else np.asarray(d, dtype=float).ravel()[:5]))
    camera = CameraModel(width, height, fx=float(k[0, 0]), fy=float(k[1, 1]), cx=float(k[0, 2]), cy=float(k[1, 2]),
                         k1=k1, k2=k2, p1=p1, p2=p2, k3=k3, name=camera_name)
    try:
        warnings = plausibility_warnings(camera)
    except CameraModelError as exc:
        raise CalibrationError(f"the calibration is not usable: {exc}; the boards do not constrain the lens "
                               "(add views that fill the image, check --board)") from None
    coverage = _corner_coverage([f.corners for f in found], width, height)
    missing = [corner for corner, ok in coverage.items() if not ok]
    hint = None
    if missing:
        hint = ("no board reached the " + ", ".join(missing) + " corner(s) of the image: add views with the board "
                "there, where distortion is strongest")
    return CalibrationResult(
        camera=camera,
        rms_px=float(solution["rms"]),
        used=[ViewResult(f.name, float(e), half_window_px=f.half_window_px)
              for f, e in zip(found, errors, strict=True)],
        rejected=rejected,
        std_fx=float(std[0]),
        std_fy=float(std[1]),
        std_cx=float(std[2]),
        std_cy=float(std[3]),
        std_distortion=tuple(float(x) for x in std[4:9]),
        coverage_hint=hint,
        corner_coverage=coverage,
        warnings=warnings,
    )


def _solve(image_points: list[np.ndarray], board: Board, size: tuple[int, int], fix_tangential: bool) -> dict:
    # The board in units of one square: the intrinsics do not depend on its size (only the
    # unused extrinsics do), and OpenCV's solver loses precision far from unit scale.
    object_points = [board.grid_squares() for _ in image_points]
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
