"""Cascaded position-attitude control, thruster mixing and the guidance state machine (no ROS import)."""
