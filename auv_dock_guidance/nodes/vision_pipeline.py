"""camera_ingest and detector as two nodes in one process, on one executor.

The same two nodes as ever (same names, parameters and topics), but frames go from the
camera's capture thread to the detector as they are, without DDS and without a copy
(camera/image_raw is still published while anyone else subscribes), and the two cores
carry one Python process fewer.
"""

from __future__ import annotations

from auv_dock_guidance.nodes.camera_ingest import CameraIngestNode
from auv_dock_guidance.nodes.common import run_nodes
from auv_dock_guidance.nodes.detector import DetectorNode


def main(args: list[str] | None = None) -> int:
    cameras: list[CameraIngestNode] = []

    def camera() -> CameraIngestNode:
        cameras.append(CameraIngestNode())
        return cameras[-1]

    def detector() -> DetectorNode:
        node = DetectorNode(subscribe=False)
        cameras[-1].frame_sinks.append(node.submit)
        return node

    return run_nodes([camera, detector], args)


if __name__ == "__main__":
    raise SystemExit(main())
