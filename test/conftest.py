"""Shared fixtures: the paper's camera, and an isolated DDS domain for tests that run ROS 2."""

from __future__ import annotations

import os
import random

import pytest

from auv_dock_guidance.geometry.camera import CameraModel, paper_camera


@pytest.fixture(scope="session")
def camera() -> CameraModel:
    return paper_camera()


@pytest.fixture(scope="session")
def domain_id() -> int:
    """A domain of our own, so parallel runs on one machine do not hear each other."""
    return random.Random(os.getpid()).randint(30, 200)
