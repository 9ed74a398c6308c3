"""Loop prevention per ROS publisher (SenderFilter): messages a bridge published
(this bridge or another) are not bridged back to LN, while a real ROS publisher on
the same topic is bridged. Through the bridge: test_auto.py
(test_messages_from_bridge_publishers_are_not_bridged_back) and test_cyclone.py."""

from ln_ros2_bridge.ros_senders import SenderFilter

BRIDGE, OTHER, FOREIGN, LATE = b"B" * 16, b"O" * 16, b"F" * 16, b"L" * 16


class FakeGraph:
    def __init__(self, **nodes):
        self.nodes = dict(nodes)
        self.lookups = 0

    def __call__(self):
        self.lookups += 1
        return dict(self.nodes)


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def make_filter(graph, clock, hold=3):
    return SenderFilter("/t", graph, lambda node: node.rsplit("/", 1)[-1].startswith("ln_ros2_bridge"),
                        hold=hold, clock=clock)


def test_bridge_publishers_are_dropped_others_forwarded():
    graph = FakeGraph()
    graph.nodes = {BRIDGE: "/ln_ros2_bridge_a", OTHER: "/ns/talker"}
    senders = make_filter(graph, FakeClock())
    assert senders.admit(BRIDGE, 1) == []
    assert senders.admit(OTHER, 2) == [2]
    assert senders.admit(BRIDGE, 3) == []
    assert senders.admit(OTHER, 4) == [4]
    assert senders.dropped == 2 and senders.is_bridge(BRIDGE) and not senders.is_bridge(OTHER)
    lookups = graph.lookups
    senders.admit(OTHER, 5)
    assert graph.lookups == lookups, "a known publisher needs no graph look-up"


def test_messages_wait_for_the_graph_to_name_their_publisher():
    graph, clock = FakeGraph(), FakeClock()
    graph.nodes = {LATE: ""}                       # discovered, node not known yet
    senders = make_filter(graph, clock)
    assert senders.admit(LATE, 1) == []
    clock.now += 0.1
    assert senders.admit(LATE, 2) == []
    graph.nodes = {LATE: "/talker"}
    clock.now += 0.1
    assert senders.admit(LATE, 3) == [1, 2, 3], "held messages first, in order"

    graph.nodes[BRIDGE] = ""                       # a bridge's publisher, found out later
    assert senders.admit(BRIDGE, 4) == []
    graph.nodes[BRIDGE] = "/ln_ros2_bridge_b"
    assert senders.resolve() == [] and senders.dropped == 1


def test_a_publisher_without_a_node_is_forwarded_after_the_pending_time():
    graph, clock = FakeGraph(), FakeClock()
    graph.nodes = {FOREIGN: ""}                    # e.g. a plain DDS participant: never gets a node
    senders = make_filter(graph, clock, hold=3)
    for i in range(5):
        assert senders.admit(FOREIGN, i) == []
        clock.now += 0.1
    assert senders.resolve() == []
    clock.now += SenderFilter.PENDING
    assert senders.resolve() == [2, 3, 4], "the newest `hold` messages, in order"
    assert senders.admit(FOREIGN, 5) == [5]


def test_publishers_that_left_are_forgotten():
    graph = FakeGraph()
    graph.nodes = {BRIDGE: "/ln_ros2_bridge", OTHER: "/talker"}
    senders = make_filter(graph, FakeClock())
    senders.admit(BRIDGE, 1)
    senders.admit(OTHER, 2)
    graph.nodes = {OTHER: "/talker"}
    senders.resolve()
    assert not senders.is_bridge(BRIDGE) and senders.admit(OTHER, 3) == [3]
