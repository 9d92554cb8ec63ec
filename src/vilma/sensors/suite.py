"""The set of sensors on a car, each optional, with its parameters."""

from __future__ import annotations

from dataclasses import dataclass

from vilma.sensors.actuator_state import ActuatorStateParams, ActuatorStateSensor
from vilma.sensors.base import Sensor
from vilma.sensors.gps import GpsParams, GpsSensor
from vilma.sensors.imu import ImuParams, ImuSensor
from vilma.sensors.odometry import OdometryParams, OdometrySensor
from vilma.sensors.pose import PoseParams, PoseSensor
from vilma.sensors.velocity import VelocityParams, VelocitySensor
from vilma.sensors.wheel_speed import WheelSpeedParams, WheelSpeedSensor
from vilma.vehicle.params import VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class SensorSuite:
    """Sensors on the car; ``None`` removes one. Defaults: every sensor at its default rate."""

    pose: PoseParams | None = PoseParams()
    velocity: VelocityParams | None = VelocityParams()
    gps: GpsParams | None = GpsParams()
    imu: ImuParams | None = ImuParams()
    wheel_speed: WheelSpeedParams | None = WheelSpeedParams()
    odometry: OdometryParams | None = OdometryParams()
    actuators: ActuatorStateParams | None = ActuatorStateParams()

    @classmethod
    def none(cls) -> SensorSuite:
        """No sensors at all (physics only)."""
        return cls(pose=None, velocity=None, gps=None, imu=None, wheel_speed=None, odometry=None, actuators=None)


def build_sensors(suite: SensorSuite, vehicle: VehicleParams) -> list[Sensor]:
    """Sensor objects for a suite, in a fixed order."""
    out: list[Sensor] = []
    if suite.pose:
        out.append(PoseSensor(suite.pose))
    if suite.velocity:
        out.append(VelocitySensor(suite.velocity))
    if suite.gps:
        out.append(GpsSensor(suite.gps))
    if suite.imu:
        out.append(ImuSensor(suite.imu))
    if suite.wheel_speed:
        out.append(WheelSpeedSensor(suite.wheel_speed, vehicle))
    if suite.odometry:
        out.append(OdometrySensor(suite.odometry, vehicle))
    if suite.actuators:
        out.append(ActuatorStateSensor(suite.actuators))
    return out
