"""Which Fast DDS transports each node process gets from the launcher."""

from auv_dock_guidance.launcher import PROFILES_VARIABLE, NodeGroup, ros_environment
from auv_dock_guidance.resources import config_file


def test_only_processes_that_carry_frames_use_shared_memory():
    group = NodeGroup(["vision_pipeline", "guidance", "serial_bridge"], env=ros_environment())
    shm, udp = str(config_file("fastdds_shm.xml")), str(config_file("fastdds_udp_only.xml"))
    assert group.environment("vision_pipeline")[PROFILES_VARIABLE] == shm
    assert group.environment("detector")[PROFILES_VARIABLE] == shm
    assert group.environment("guidance")[PROFILES_VARIABLE] == udp
    assert group.environment("serial_bridge")[PROFILES_VARIABLE] == udp


def test_a_profile_the_user_chose_is_kept_for_every_process(monkeypatch, tmp_path):
    mine = str(tmp_path / "my_profile.xml")
    monkeypatch.setenv(PROFILES_VARIABLE, mine)
    group = NodeGroup(["guidance"], env=ros_environment())
    assert group.environment("guidance")[PROFILES_VARIABLE] == mine
