"""Thin rclpy wrappers around the core: one node per file, a console script each."""
