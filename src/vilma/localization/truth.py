"""The simulator's exact pose, as the paper's controllers used (MORSE's ``Pose`` and ``Velocity``)."""

from __future__ import annotations

from vilma.core.messages import PoseEstimate
from vilma.sensors import Readings


class TruthEstimator:
    """Passes the ``pose`` and ``velocity`` readings through (uncertainty 0)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.estimate: PoseEstimate | None = None
        self.speed = self.yaw_rate = 0.0
        """Of the latest velocity reading: forward speed [m/s] and yaw rate [rad/s]."""

    def update(self, readings: dict[str, Readings]) -> PoseEstimate | None:
        vel = readings.get("velocity")
        if vel is not None and len(vel):
            v = vel.latest()
            self.speed, self.yaw_rate = v.vx, v.wz
        pose = readings.get("pose")
        if pose is not None and len(pose):
            p = pose.latest()
            self.estimate = PoseEstimate(p.stamp_ns, p.x, p.y, p.yaw, self.speed, self.yaw_rate, 0.0, 0.0, 0.0)
        return self.estimate
