"""Fixtures for tests that run real ROS 2 nodes: an isolated DDS domain per test session."""

from __future__ import annotations

import os
import random

import pytest


@pytest.fixture(scope="session")
def domain_id() -> int:
    """A domain of our own, so parallel runs on one machine do not hear each other."""
    return random.Random(os.getpid()).randint(30, 200)
