"""Shared fixtures: the paper's camera and rendered scenes with ground truth."""

from __future__ import annotations

import pytest

from auv_dock_guidance.geometry.camera import CameraModel, paper_camera


@pytest.fixture(scope="session")
def camera() -> CameraModel:
    return paper_camera()
