"""What the shore tools say about the domain they listen on."""

from auv_dock_guidance.cli.shore import NO_PUBLISHERS_AFTER_S, ShoreView


def test_the_monitor_says_when_no_one_publishes_and_when_the_publishers_are_gone():
    view = ShoreView(domain=77)
    view.count_publishers(0)
    assert view.domain_note() is None  # discovery takes a moment
    view.started -= NO_PUBLISHERS_AFTER_S + 1
    assert "no publishers of the debug topics on ROS domain 77" in view.domain_note()
    view.count_publishers(5)
    assert view.domain_note() is None
    view.count_publishers(0)
    assert view.domain_note() == "the publishers on ROS domain 77 are gone (the run ended?)"
