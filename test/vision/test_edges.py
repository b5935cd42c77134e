import numpy as np
import pytest

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.sim.evaluate import edge_comparison
from auv_dock_guidance.vision.edges import improved_canny, pratt_figure_of_merit, psnr, traditional_canny


def _step_image(noise: float = 0.0, seed: int = 0) -> np.ndarray:
    image = np.full((64, 64), 40.0)
    image[:, 32:] = 160.0
    image += np.random.default_rng(seed).normal(0, noise, image.shape)
    return np.clip(image, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("canny", [improved_canny, traditional_canny])
def test_both_cannys_find_a_vertical_step(canny):
    edges = canny(_step_image(), 5.0, 15.0)
    columns = np.nonzero(edges.any(axis=0))[0]
    assert set(columns) <= {31, 32}
    assert edges[:, 31:33].any(axis=1)[4:-4].all()


def test_psnr_of_identical_images_is_infinite_and_known_for_one_wrong_pixel():
    a = np.zeros((10, 10), np.uint8)
    assert psnr(a, a) == float("inf")
    b = a.copy()
    b[0, 0] = 255
    assert psnr(a, b) == pytest.approx(20.0)  # MSE = 255^2 / 100


def test_pratt_figure_of_merit_is_one_for_perfect_edges_and_falls_with_offset():
    ideal = np.zeros((20, 20), np.uint8)
    ideal[:, 10] = 255
    assert pratt_figure_of_merit(ideal, ideal) == pytest.approx(1.0)
    shifted = np.roll(ideal, 2, axis=1)
    assert pratt_figure_of_merit(shifted, ideal) == pytest.approx(1 / (1 + 4 / 9))
    assert pratt_figure_of_merit(np.zeros_like(ideal), ideal) == 0.0


def test_improved_canny_beats_traditional_on_noisy_renders():
    report = edge_comparison(paper_camera(), frames=4, seed=11)
    assert report["improved_psnr_db"] > report["traditional_psnr_db"]
    assert report["improved_pfom"] > report["traditional_pfom"]
