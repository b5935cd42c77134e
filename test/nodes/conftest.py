"""rclpy for tests that run nodes inside the test process."""

import pytest
import rclpy


@pytest.fixture()
def ros(domain_id):
    rclpy.init(domain_id=domain_id)
    yield
    rclpy.try_shutdown()
