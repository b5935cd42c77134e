"""camera_ingest and detector as two nodes in one process, on one executor.

The same two nodes as ever (same names, parameters and topics), but 6 MB frames pass
inside one DDS participant instead of between processes, and the two cores carry one
Python process fewer.
"""

from __future__ import annotations

from auv_dock_guidance.nodes.camera_ingest import CameraIngestNode
from auv_dock_guidance.nodes.common import run_nodes
from auv_dock_guidance.nodes.detector import DetectorNode


def main(args: list[str] | None = None) -> int:
    return run_nodes([CameraIngestNode, DetectorNode], args)


if __name__ == "__main__":
    raise SystemExit(main())
