"""littledog_mlsim.nodes.spinner.Spinner: the executor thread a controller process can always
shut down (nodes destroyed on the spin thread between waits; bounded waits; close joins)."""
from __future__ import annotations

import threading

import pytest

from rosharness import DOMAIN_ID  # noqa: F401  (first: it sets the test domain)
from rclpy.node import Node
from std_msgs.msg import String

from littledog_mlsim.nodes.spinner import Spinner
from waiting import wait_until


class RecordingNode(Node):
    """Says which thread destroyed it."""

    destroyed_by: threading.Thread | None = None

    def destroy_node(self) -> None:
        RecordingNode.destroyed_by = threading.current_thread()
        super().destroy_node()


def test_messages_flow_and_destroy_runs_on_the_spin_thread():
    spinner = Spinner(DOMAIN_ID, name="spinner-under-test", period=0.02, timeout=10.0)
    try:
        got: list[str] = []
        sub = spinner.add(RecordingNode("listener", context=spinner.context))
        sub.create_subscription(String, "/spinner_test", lambda m: got.append(m.data), 10)
        talker = spinner.node("talker")
        pub = talker.create_publisher(String, "/spinner_test", 10)
        wait_until(lambda: pub.get_subscription_count() >= 1, what="the listener")
        for k in range(5):
            pub.publish(String(data=f"m{k}"))
        wait_until(lambda: len(got) == 5, what="five messages")
        assert got == [f"m{k}" for k in range(5)]

        spinner.destroy(sub)                       # returns when the spin thread has done it
        assert RecordingNode.destroyed_by is spinner.thread
        assert sub not in spinner.executor.get_nodes()
        with pytest.raises(Exception, match="destruction was requested|destroyed|invalid"):
            with sub.handle:
                pass
        wait_until(lambda: pub.get_subscription_count() == 0, what="the listener to leave")
    finally:
        spinner.close()
    assert not spinner.thread.is_alive()
    assert not spinner.context.ok()
    spinner.close()                                # idempotent


def test_close_with_nodes_left_destroys_them_after_the_thread_stopped():
    with Spinner(DOMAIN_ID, name="spinner-close", period=0.02) as spinner:
        node = spinner.add(RecordingNode("left_over", context=spinner.context))
    assert not spinner.thread.is_alive()
    # the thread had stopped, so nothing waited on the node: the caller destroyed it
    assert RecordingNode.destroyed_by is threading.main_thread()
    assert node not in spinner.executor.get_nodes()
