"""Where the shipped configuration files are, in a checkout, a pip install or a colcon install."""

from __future__ import annotations

import sys
from pathlib import Path

PACKAGE = "auv_dock_guidance"


def config_dir() -> Path:
    """The folder holding camera_info.yaml, dock_guidance.yaml and friends.

    Looked for next to the source tree (checkout, editable install), then under the
    environment's share/ folder (pip install, colcon install), then via the ament index.
    """
    candidates = [Path(__file__).resolve().parents[1] / "config", Path(sys.prefix) / "share" / PACKAGE / "config"]
    for candidate in candidates:
        if (candidate / "dock_guidance.yaml").is_file():
            return candidate
    try:
        from ament_index_python.packages import get_package_share_directory

        shared = Path(get_package_share_directory(PACKAGE)) / "config"
        if shared.is_dir():
            return shared
    except (ImportError, LookupError, ValueError):
        pass
    raise FileNotFoundError(f"cannot find the {PACKAGE} config folder (looked in {', '.join(map(str, candidates))})")


def config_file(name: str) -> Path:
    return config_dir() / name
