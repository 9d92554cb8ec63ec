"""A ROS 1 node for test_ros1.py, run in its own process: watches /pose and /velocity, publishes on /cmd.

``ros1_probe.py drive FORCE``: prints the first pose, then drives with ``[0, FORCE, 0]`` (at each pose, at least
every 0.1 s) and prints the first pose 0.5 m further along x, and the last pose and speed seen when it stopped
publishing (5 m further along), then the first pose at rest (speed under 0.05 m/s).

``ros1_probe.py flood N``: prints the first pose, publishes N std_msgs/String, then N times a 1-number command
and a NaN command on /cmd, then drives as above until the car is 0.5 m further (printed), and prints how long all
that took [s].

Each finding is one JSON line; exits 1 if one does not come within 30 s. It imports only what
vilma.record.ros1.rospy_or_reason checks (the test's skip guard).
"""

from __future__ import annotations

import json
import math
import sys
import threading
import time
import warnings

from vilma.record.ros1 import rospy_or_reason

rospy, _ = rospy_or_reason()  # puts Debian's ROS packages on the path
from geometry_msgs.msg import PoseStamped, TwistStamped  # noqa: E402
from std_msgs.msg import Float64MultiArray, String  # noqa: E402

warnings.filterwarnings("ignore", "The publisher should be created with an explicit keyword argument 'queue_size'")
TIMEOUT = 30.0
"""How long to wait for each finding [s of wall time]."""


class Car:
    """The latest pose and speed the bridge published."""

    def __init__(self) -> None:
        self.cond = threading.Condition()
        self.pose: PoseStamped | None = None
        self.poses = 0
        self.speed = math.nan
        rospy.Subscriber("/pose", PoseStamped, self._pose, queue_size=100)
        rospy.Subscriber("/velocity", TwistStamped, self._velocity, queue_size=100)

    def _pose(self, p: PoseStamped) -> None:
        with self.cond:
            self.pose, self.poses = p, self.poses + 1
            self.cond.notify_all()

    def _velocity(self, v: TwistStamped) -> None:
        with self.cond:
            self.speed = math.hypot(v.twist.linear.x, v.twist.linear.y)

    def plain(self) -> dict:
        p = self.pose
        return {"stamp_ns": p.header.stamp.secs * 10**9 + p.header.stamp.nsecs, "frame": p.header.frame_id,
                "x": p.pose.position.x, "y": p.pose.position.y, "speed": self.speed}

    def wait(self, done, publish=None) -> dict | None:
        """The car (plain) once ``done(car)`` holds, calling ``publish`` every 0.1 s meanwhile; None on timeout."""
        deadline = time.monotonic() + TIMEOUT
        with self.cond:
            while time.monotonic() < deadline:
                if done(self):
                    return self.plain()
                if publish is not None:
                    publish()
                self.cond.wait(timeout=0.1)
        return None


def connected(pub: rospy.Publisher) -> rospy.Publisher:
    """``pub`` once the bridge subscribes to it (what is published before is lost)."""
    deadline = time.monotonic() + TIMEOUT
    while pub.get_num_connections() == 0:
        if time.monotonic() > deadline:
            sys.exit("the bridge did not subscribe to /cmd")
        time.sleep(0.05)
    return pub


def say(finding: dict | None, what: str) -> dict:
    """Print ``finding`` as a JSON line; exit 1 if it is None (``what`` did not come)."""
    if finding is None:
        sys.exit(f"timed out waiting for {what}")
    print(json.dumps(finding), flush=True)
    return finding


def flood(n: int) -> None:
    """``n`` messages of another type on /cmd, then ``n`` times a command of one number and one with NaN."""
    strings = connected(rospy.Publisher("/cmd", String, queue_size=None))  # no queue: none is dropped here
    for _ in range(n):
        strings.publish(String(data="forward"))
    strings.unregister()
    bad = connected(rospy.Publisher("/cmd", Float64MultiArray, queue_size=None))
    for _ in range(n):  # interleaved: the bridge keeps the last 10 of a burst
        bad.publish(Float64MultiArray(data=[1.0]))
        bad.publish(Float64MultiArray(data=[math.nan, 3000.0, 0.0]))
    bad.unregister()


def main() -> int:
    rospy.init_node("vilma_probe", anonymous=True, disable_signals=True)
    car = Car()
    first = say(car.wait(lambda c: c.poses >= 2), "a pose")
    t0 = time.monotonic()
    mode, arg = sys.argv[1], sys.argv[2]
    if mode == "flood":
        flood(int(arg))
    force = 3000.0 if mode == "flood" else float(arg)
    cmd = connected(rospy.Publisher("/cmd", Float64MultiArray, queue_size=None))

    def forward() -> None:
        cmd.publish(Float64MultiArray(data=[0.0, force, 0.0]))

    say(car.wait(lambda c: c.pose.pose.position.x > first["x"] + 0.5, forward), "the car to move")
    if mode == "flood":
        say({"seconds": time.monotonic() - t0}, "")
        return 0
    say(car.wait(lambda c: c.pose.pose.position.x > first["x"] + 5.0, forward), "the car to go 5 m")
    cmd.unregister()  # the publisher stops
    say(car.wait(lambda c: c.speed < 0.05), "the car to come to rest")
    return 0


if __name__ == "__main__":
    sys.exit(main())
