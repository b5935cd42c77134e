"""Camera model, calibration and the marker pose equations (no ROS import)."""
