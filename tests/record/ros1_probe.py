"""A ROS 1 node for test_ros1.py, run in its own process: subscribes to /pose, then drives through /cmd.

Prints one JSON line per finding: the first pose, then the first pose 0.5 m further along x after it
published forward drive commands. Exits 1 if either does not come within its timeout.
"""

from __future__ import annotations

import json
import sys
import threading
import time

sys.path.append("/usr/lib/python3/dist-packages")

import rospy
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Float64MultiArray


def _plain(p: PoseStamped) -> dict:
    return {"frame": p.header.frame_id, "stamp_ns": p.header.stamp.secs * 10**9 + p.header.stamp.nsecs,
            "x": p.pose.position.x, "y": p.pose.position.y}


def main() -> int:
    rospy.init_node("vilma_probe", anonymous=True, disable_signals=True)
    poses: list[PoseStamped] = []
    cond = threading.Condition()

    def take(msg: PoseStamped) -> None:
        with cond:
            poses.append(msg)
            cond.notify_all()

    rospy.Subscriber("/pose", PoseStamped, take, queue_size=100)
    with cond:
        if not cond.wait_for(lambda: len(poses) >= 2, timeout=60):
            print("no pose came", file=sys.stderr)
            return 1
        first = poses[-1]
    print(json.dumps(_plain(first)), flush=True)
    pub = rospy.Publisher("/cmd", Float64MultiArray, queue_size=10)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        pub.publish(Float64MultiArray(data=[0.0, float(sys.argv[1]), 0.0]))
        with cond:
            cond.wait(timeout=0.2)
            last = poses[-1]
        if abs(last.pose.position.x - first.pose.position.x) > 0.5:
            print(json.dumps(_plain(last)), flush=True)
            return 0
    print("the car did not move", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
