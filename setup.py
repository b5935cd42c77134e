"""ament_python package: builds with colcon on a ROS 2 install and with pip anywhere."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "auv_dock_guidance"

setup(
    name=PACKAGE,
    version="0.1.0",
    description="Monocular visual guidance for AUV terminal docking onto an LED-ring marker",
    license="Apache-2.0",
    python_requires=">=3.10",
    packages=find_packages(exclude=["test", "test.*"]),
    package_data={PACKAGE: ["py.typed"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch", glob("launch_scripts/*.launch.py")),
        (f"share/{PACKAGE}/config", glob("config/*.yaml") + glob("config/*.xml") + glob("config/*.json")),
    ],
    install_requires=["setuptools", "numpy", "pyyaml", "pyserial"],
    zip_safe=True,
    entry_points={
        "console_scripts": [
            "auv-dock = auv_dock_guidance.cli.main:main",
            "dock_camera_ingest = auv_dock_guidance.nodes.camera_ingest:main",
            "dock_detector = auv_dock_guidance.nodes.detector:main",
            "dock_guidance = auv_dock_guidance.nodes.guidance:main",
            "dock_serial_bridge = auv_dock_guidance.nodes.serial_bridge:main",
            "dock_vision_pipeline = auv_dock_guidance.nodes.vision_pipeline:main",
        ],
    },
)
