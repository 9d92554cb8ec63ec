"""The in-process bus and the helpers every bus shares."""

from __future__ import annotations

import logging
import threading

from vilma.bus import BoundedQueue, Latest, LocalBus, topic
from vilma.core.messages import Pose, Reply, SimControl


def _pose(t: int) -> Pose:
    return Pose(t, float(t), 0.0, 0.0, 0.0, 0.0, 0.0)


def test_publish_reaches_every_subscriber_until_closed():
    bus, got_a, got_b = LocalBus(), [], []
    key = topic("pose")
    sub = bus.subscribe(key, got_a.append)
    bus.subscribe(key, got_b.append)
    bus.publish(key, _pose(1))
    sub.close()
    bus.publish(key, _pose(2))
    bus.publish(topic("gps"), _pose(3))  # another topic: nobody here listens
    assert [m.stamp_ns for m in got_a] == [1] and [m.stamp_ns for m in got_b] == [1, 2]


def test_a_failing_subscriber_is_logged_and_the_others_still_get_it(caplog):
    bus, got = LocalBus(), []
    key = topic("pose")
    bus.subscribe(key, lambda m: 1 / 0)
    bus.subscribe(key, got.append)
    with caplog.at_level(logging.ERROR):
        bus.publish(key, _pose(1))
    assert len(got) == 1 and "subscriber of vilma/vilma/pose failed" in caplog.text


def test_latest_and_bounded_queue():
    bus = LocalBus()
    key = topic("pose")
    latest, queue = Latest(bus, key), BoundedQueue(bus, key, maxsize=3)
    for t in range(5):
        bus.publish(key, _pose(t))
    assert latest.value.stamp_ns == 4 and latest.count == 5
    assert [m.stamp_ns for m in queue.drain()] == [2, 3, 4] and queue.dropped == 2
    threading.Timer(0.05, bus.publish, (key, _pose(9))).start()
    assert queue.wait(lambda m: m.stamp_ns == 9, timeout=5.0).stamp_ns == 9
    assert queue.wait(lambda m: True, timeout=0.05) is None


def test_request_reply():
    bus = LocalBus()
    key = topic("sim/cmd")
    nobody = Reply(ok=False, error="nobody answers on vilma/vilma/sim/cmd")
    assert bus.request(key, SimControl(action="reset")) == nobody
    bus.serve(key, lambda m: Reply(ok=m.action == "reset"))
    assert bus.request(key, SimControl(action="reset")).ok
    bus.close()
    assert not bus.request(key, SimControl(action="reset")).ok


def test_a_bus_and_its_helpers_in_a_with_block_are_closed_even_when_the_block_raises():
    got = []
    try:
        with LocalBus() as bus, Latest(bus, topic("gps")) as latest, BoundedQueue(bus, topic("imu")) as queue:
            assert isinstance(bus, LocalBus) and isinstance(latest, Latest) and isinstance(queue, BoundedQueue)
            bus.subscribe(topic("pose"), got.append)
            bus.publish(topic("pose"), _pose(1))
            raise RuntimeError("boom")
    except RuntimeError as e:
        assert str(e) == "boom"  # the exception goes on
    for name in ("pose", "gps", "imu"):
        bus.publish(topic(name), _pose(2))
    assert [m.stamp_ns for m in got] == [1] and latest.value is None and queue.drain() == []
    bus.close()  # a second close does nothing
