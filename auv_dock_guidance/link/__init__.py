"""The serial link to the main controller: protocol, transport, failsafe bridge, mock controller (no ROS import)."""
