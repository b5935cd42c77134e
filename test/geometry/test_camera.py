import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from auv_dock_guidance.errors import CameraModelError
from auv_dock_guidance.geometry.camera import PAPER_FOCAL_PX, CameraModel, paper_camera, plausibility_warnings

CONFIG = Path(__file__).resolve().parents[2] / "config" / "camera_info.yaml"


def test_config_camera_info_is_the_papers_table_2():
    assert CameraModel.from_yaml(CONFIG) == paper_camera()


def test_yaml_round_trip(tmp_path, camera):
    path = tmp_path / "cam.yaml"
    path.write_text(yaml.safe_dump(camera.to_yaml_dict()))
    assert CameraModel.from_yaml(path) == camera


def test_from_camera_info_fields_matches_yaml(camera):
    k = camera.matrix.ravel().tolist()
    built = CameraModel.from_camera_info(1920, 1080, k, list(camera.distortion), "plumb_bob", name="dock_camera")
    assert built == camera


def test_undistortion_inverts_projection_inside_the_fold(camera):
    rng = np.random.default_rng(0)
    xy = rng.uniform(-0.45, 0.45, size=(500, 2)) * [1.0, 0.55]
    pixels = camera.normalized_to_pixels(xy)
    back, valid = camera.pixels_to_normalized(pixels)
    assert valid.all()
    np.testing.assert_allclose(back, xy, atol=1e-9)


def test_table_2_lens_folds_near_930_px(camera):
    fold = camera.fold_radius
    assert fold is not None and 0.72 < fold < 0.74
    fold_px = camera.normalized_to_pixels(np.array([fold, 0.0]))[0] - camera.cx
    assert 920 < fold_px < 940


def test_image_corners_beyond_the_fold_are_flagged_not_returned_as_garbage(camera):
    corners = np.array([[0.0, 0.0], [1919.0, 0.0], [0.0, 1079.0], [1919.0, 1079.0]])
    _, valid = camera.pixels_to_normalized(corners)
    assert not valid.any()
    centre = np.array([[camera.cx, camera.cy], [1500.0, 800.0]])
    assert camera.pixels_to_normalized(centre)[1].all()


def test_projection_beyond_the_fold_is_invalid(camera):
    points = np.array([[0.0, 0.0, 1.0], [0.8, 0.0, 1.0], [0.0, 0.0, -1.0]])
    _, valid = camera.project(points)
    assert valid.tolist() == [True, False, False]


def test_camera_without_distortion_has_no_fold():
    cam = CameraModel(width=640, height=480, fx=500, fy=500, cx=320, cy=240)
    assert cam.fold_radius is None
    _, valid = cam.pixels_to_normalized(np.array([[0.0, 0.0]]))
    assert valid.all()


def test_scaled_camera_keeps_normalized_geometry(camera):
    half = camera.scaled(0.5)
    xy = np.array([[0.1, -0.2], [0.3, 0.1]])
    np.testing.assert_allclose(half.normalized_to_pixels(xy), (camera.normalized_to_pixels(xy) + 0.5) * 0.5 - 0.5)


def test_the_reference_focal_length_is_the_papers_camera(camera):
    assert PAPER_FOCAL_PX == pytest.approx(camera.focal_px)


def test_images_resized_from_the_calibrated_size_get_the_scaled_model(camera):
    assert camera.for_image(1920, 1080) is camera
    half = camera.for_image(960, 540)
    assert (half.width, half.height) == (960, 540) and half.fx == pytest.approx(camera.fx / 2)
    third = camera.for_image(640, 360)  # 1080 / 3 rounds exactly; the model keeps the images' size
    assert (third.width, third.height) == (640, 360) and third.cy == pytest.approx((camera.cy + 0.5) / 3 - 0.5)
    with pytest.raises(CameraModelError, match=r"640x480 .* not a uniform resize"):
        camera.for_image(640, 480)  # a crop or another camera: never guessed


@pytest.mark.parametrize(
    "text, message",
    [
        ("image_width: 0\nimage_height: 10\n", "image_width 0 is not a positive integer"),
        ("just a string", "expected a mapping"),
        ("image_width: [1\n", "not valid YAML"),
        (
            "image_width: 10\nimage_height: 10\ncamera_matrix: {data: [1, 0, 5, 0, .nan, 5, 0, 0, 1]}\n"
            "distortion_coefficients: {data: []}\n",
            "NaN or infinity",
        ),
        (
            "image_width: 10\nimage_height: 10\ncamera_matrix: {data: [1, 0, 5]}\n"
            "distortion_coefficients: {data: []}\n",
            "expected 9",
        ),
        ("image_width: 10\nimage_height: 10\n", "camera_matrix is missing"),
    ],
)
def test_malformed_camera_info_is_named_in_the_error(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(CameraModelError, match=message) as info:
        CameraModel.from_yaml(path)
    assert str(path) in str(info.value)


def test_missing_camera_info_file(tmp_path):
    with pytest.raises(CameraModelError, match="cannot read"):
        CameraModel.from_yaml(tmp_path / "nope.yaml")


def _camera_info_file(tmp_path, camera: CameraModel) -> Path:
    path = tmp_path / "implausible.yaml"
    path.write_text(yaml.safe_dump(camera.to_yaml_dict()))
    return path


def test_the_papers_calibration_is_plausible(camera, caplog):
    assert plausibility_warnings(camera) == []
    CameraModel.from_yaml(CONFIG)
    assert "implausible" not in caplog.text


def test_a_principal_point_far_outside_the_image_is_named(tmp_path, caplog):
    pinhole = CameraModel(width=640, height=480, fx=500, fy=500, cx=99999.0, cy=240)
    assert plausibility_warnings(pinhole) == ["principal point cx 99999 px lies outside the image (0-639 px)"]
    path = _camera_info_file(tmp_path, pinhole)
    assert CameraModel.from_yaml(path).cx == 99999.0  # loaded, and said once
    CameraModel.from_yaml(path)
    lines = [r.getMessage() for r in caplog.records]
    assert lines == [f"{path}: implausible calibration: principal point cx 99999 px lies outside the image (0-639 px)"]


def test_a_principal_point_that_puts_the_whole_image_beyond_the_fold_is_refused(tmp_path, camera):
    path = _camera_info_file(tmp_path, dataclasses.replace(camera, cx=99999.0))
    with pytest.raises(CameraModelError, match=r"cx 99999 px lies outside.*over the whole image") as info:
        CameraModel.from_yaml(path)
    assert str(path) in str(info.value)


def test_distortion_that_squeezes_the_image_is_named(camera, caplog):
    k = camera.matrix.ravel()
    squeezed = CameraModel.from_camera_info(1920, 1080, k, [50, 80, 0, 0, 90], source="/camera/camera_info")
    assert squeezed.k3 == 90
    assert "/camera/camera_info: implausible calibration: distortion k1 50, k2 80, p1 0, p2 0, k3 90 scales " \
           "image radii by 3.25" in caplog.text


def test_distortion_that_folds_over_most_of_the_image_is_refused(camera):
    k = camera.matrix.ravel()
    with pytest.raises(CameraModelError, match=r"k1 50, k2 80, p1 90, .* no valid undistortion over 91 % of the image"):
        CameraModel.from_camera_info(1920, 1080, k, [50, 80, 90, 0, 0])
    with pytest.raises(CameraModelError, match="expected 0, 4 or 5"):
        CameraModel.from_camera_info(1920, 1080, k, [50, 80, 90])


def test_a_lens_folding_over_a_third_of_the_image_is_warned_about(camera):
    strong = dataclasses.replace(camera, k1=-0.9, k2=0.0, k3=0.0)
    assert plausibility_warnings(strong) == [
        "distortion k1 -0.9, k2 0, p1 0, p2 0, k3 0 has no valid undistortion over 37 % of the image (more than 25 %)"
    ]


def test_an_approximate_camera_has_its_principal_point_at_the_centre_and_no_distortion():
    from auv_dock_guidance.geometry.camera import ApproximateLens, approximate_camera

    camera = approximate_camera(720, 576, focal_px=650.0)
    assert camera.approximate and (camera.cx, camera.cy) == (359.5, 287.5)
    assert camera.distortion == (0.0, 0.0, 0.0, 0.0, 0.0) and camera.fx == camera.fy == 650.0
    wide = ApproximateLens(hfov_deg=90.0).camera_for(1280, 720)
    assert wide.fx == pytest.approx(640.0)
    half = camera.for_image(360, 300)  # another size: the same field of view across the width
    assert half.approximate and half.fx == pytest.approx(325.0) and half.cy == pytest.approx(149.5)


@pytest.mark.parametrize("kwargs, message", [({}, "either"), ({"focal_px": 5.0, "hfov_deg": 60.0}, "either"),
                                             ({"focal_px": -1.0}, "positive"), ({"hfov_deg": 200.0}, "1 to 170")])
def test_an_approximate_lens_needs_one_sensible_number(kwargs, message):
    from auv_dock_guidance.geometry.camera import ApproximateLens

    with pytest.raises(CameraModelError, match=message):
        ApproximateLens(**kwargs)
