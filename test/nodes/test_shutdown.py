"""A node process always ends: a teardown that hangs is cut short, and says so."""

import signal
import subprocess
import sys
import textwrap
import time

from auv_dock_guidance.launcher import ros_environment
from auv_dock_guidance.nodes.common import TEARDOWN_EXIT_CODE

STUCK_AT_EXIT = textwrap.dedent("""
    import time
    from rclpy.node import Node
    from auv_dock_guidance.nodes.common import run_nodes

    class Stuck(Node):
        def __init__(self):
            super().__init__("stuck_at_exit")
            self.create_timer(0.02, lambda: None)

        def destroy_node(self):
            time.sleep(3600)  # what a hung DDS teardown looks like from here

    raise SystemExit(run_nodes([Stuck]))
""")


def test_a_node_whose_teardown_hangs_still_exits_and_says_so(domain_id):
    process = subprocess.Popen([sys.executable, "-c", STUCK_AT_EXIT], env=ros_environment(domain_id=domain_id),
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)  # up and spinning
    assert process.poll() is None
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=20)
    assert process.returncode == TEARDOWN_EXIT_CODE
    assert "shutdown did not finish within 4 s" in stderr
