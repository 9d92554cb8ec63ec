"""``vilma ros1-bridge``: vilma's bus on a real ROS 1 master, with the original VILMA's topics.

Publishes what the original program subscribed to (vilma-original.md section 5),
stamped with sim time:

================ ================================ ==============================================
``/pose``        geometry_msgs/PoseStamped        frame ``/map``; quaternion from roll, pitch, yaw
``/velocity``    geometry_msgs/TwistStamped       linear: world-frame velocity [m/s] (as MORSE's
                                                  sensor); angular: body rates [rad/s]
``/gps``         sensor_msgs/NavSatFix            latitude, longitude [deg], altitude [m]
``/imu``         sensor_msgs/Imu                  orientation, angular velocity, specific force
``/wheelspeed``  std_msgs/Float64MultiArray       ``[fl, fr, rl, rr]`` [rad/s]
================ ================================ ==============================================

and takes commands on ``/cmd`` (std_msgs/Float64MultiArray ``[steer rad, drive N, brake N]``, optionally
``velocity_limit`` [m/s] after them; drive and brake are forces at the wheels), which it puts on the bus as
:class:`~vilma.core.messages.ActuatorCommand`, stamped with sim time and marked autonomous: the simulator's
watchdog stops the car when they stop coming (publish them more often than its timeout, 0.5 s by default). A
fifth number (the ``autonomous`` flag of vilma's own command layout) is taken and ignored: no command from ROS
is held without the watchdog. Anything else on ``/cmd`` (another message type, the wrong count of numbers, NaN)
is dropped with a one-line warning, at most one a second per kind of fault. Camera images and laser scans are
not bridged (the original had no such sensors); ``vilma export rosbag2`` carries them to ROS 2.

ROS 1 comes from Debian (``ros-core python3-rospy python3-geometry-msgs python3-sensor-msgs
python3-std-msgs``) and its Python packages live in ``/usr/lib/python3/dist-packages``: run the bridge with
that folder on the path (see the README). ``rospy`` is imported only here.
"""

from __future__ import annotations

import importlib
import logging
import math
import sys
import threading
from pathlib import Path

from vilma.bus.base import Bus
from vilma.bus.topics import topic
from vilma.core import messages as m
from vilma.core.closing import Closeable
from vilma.core.geometry import quaternion_from_euler
from vilma.core.ratelimit import WarningThrottle

log = logging.getLogger(__name__)

CMD_TOPIC = "/cmd"
"""Where the bridge takes actuator commands."""


DEBIAN_PACKAGES = "/usr/lib/python3/dist-packages"
"""Where Debian's ROS 1 Python packages are."""
ROS_MODULES = ("rospy", "geometry_msgs.msg", "sensor_msgs.msg", "std_msgs.msg")
"""The ROS 1 modules the bridge imports."""
SHUTDOWN_TIMEOUT = 0.5
"""How long :func:`shutdown_node` waits for rospy to unregister from the master and close its servers [s]."""


def rospy_or_reason() -> tuple[object | None, str]:
    """``rospy`` if it and the message modules of :data:`ROS_MODULES` can be imported, else None and why not
    (one line).

    If they are not on the path, Debian's packages folder is tried, appended last (so that the packages of
    vilma's own environment still come first).
    """
    try:
        import rospy  # noqa: F401
    except ImportError:
        if Path(DEBIAN_PACKAGES).is_dir() and DEBIAN_PACKAGES not in sys.path:
            sys.path.append(DEBIAN_PACKAGES)
    try:
        modules = [importlib.import_module(name) for name in ROS_MODULES]
    except ImportError as e:
        return None, (f"ROS 1 is not importable: {e}; apt-get install ros-core python3-rospy "
                      "python3-geometry-msgs python3-sensor-msgs python3-std-msgs, and put "
                      "/usr/lib/python3/dist-packages on PYTHONPATH")
    return modules[0], ""


class CommandMessageError(ValueError):
    """A message on the command topic that is not a command; ``cause`` names the kind of fault."""

    def __init__(self, cause: str, message: str) -> None:
        super().__init__(message)
        self.cause = cause


def command_numbers(buff: bytes, header: dict[str, str]) -> tuple[float, ...]:
    """``[steer, drive, brake]`` and the optional ``velocity_limit`` (see the module docstring) of a serialized
    ROS message with its connection ``header`` (its ``type``, ``md5sum`` and ``callerid``).

    Raises:
        CommandMessageError: not a std_msgs/Float64MultiArray, not 3 to 5 numbers, or NaN or infinity
            (``velocity_limit`` may be +inf: no limit).
    """
    import genpy
    from std_msgs.msg import Float64MultiArray

    sender = f"from {header.get('callerid', '?')}"
    if header.get("md5sum") != Float64MultiArray._md5sum:
        raise CommandMessageError("type", f"{sender}: a {header.get('type', '?')} is not a command; publish "
                                          "std_msgs/Float64MultiArray [steer rad, drive N, brake N]")
    try:
        d = tuple(Float64MultiArray().deserialize(buff).data)
    except genpy.DeserializationError as e:
        raise CommandMessageError("unreadable", f"{sender}: an unreadable std_msgs/Float64MultiArray ({e})") \
            from None
    if not 3 <= len(d) <= 5:
        raise CommandMessageError("length", f"{sender}: a command is [steer rad, drive N, brake N] and optionally "
                                            f"velocity_limit m/s (a fifth number is ignored), got {len(d)} numbers")
    if not all(math.isfinite(v) for v in d[:3]) or (len(d) > 3 and not (math.isfinite(d[3]) or d[3] == math.inf)):
        raise CommandMessageError("not finite", f"{sender}: a command's numbers must be finite (velocity_limit may "
                                                f"be inf), got {list(d[:4])}")
    return d[:4]


class Ros1Bridge(Closeable):
    """Car ``car``'s topics on ``bus`` published to ROS 1, and ``/cmd`` taken from it (see the module docstring).

    ``rospy.init_node`` must have been called (:func:`init_node`).
    """

    def __init__(self, bus: Bus, car: str = "vilma", cmd_topic: str = CMD_TOPIC) -> None:
        import rospy
        from geometry_msgs.msg import PoseStamped, TwistStamped
        from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus
        from std_msgs.msg import Float64MultiArray, MultiArrayDimension

        self._rospy, self.bus, self.car = rospy, bus, car
        self._types = (PoseStamped, TwistStamped, Imu, NavSatFix, NavSatStatus, Float64MultiArray, MultiArrayDimension)
        self._pubs = {name: rospy.Publisher(ros, typ, queue_size=50) for name, ros, typ in (
            ("pose", "/pose", PoseStamped), ("velocity", "/velocity", TwistStamped), ("gps", "/gps", NavSatFix),
            ("imu", "/imu", Imu), ("wheel_speed", "/wheelspeed", Float64MultiArray))}
        self._stamp_ns = 0
        self._lock = threading.Lock()
        self.commands = 0
        """Commands taken from ROS so far."""
        self.cmd_topic = cmd_topic
        self._warnings = WarningThrottle(log)
        self._subs = [bus.subscribe(topic(name, car), self._taker(name)) for name in self._pubs]
        self._subs.append(bus.subscribe(topic("sim/status", car), self._clock))
        # any type, so that a message of another type is told about here rather than refused by rospy unseen
        self._cmd_sub = rospy.Subscriber(cmd_topic, rospy.AnyMsg, self._command, queue_size=10)

    def _clock(self, status: m.SimStatus) -> None:
        with self._lock:
            self._stamp_ns = status.stamp_ns

    def _stamp(self, stamp_ns: int):
        return self._rospy.Time(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)

    def _taker(self, name: str):
        convert = getattr(self, f"_{name}")
        pub = self._pubs[name]

        def take(msg: m.Message) -> None:
            pub.publish(convert(msg))
        return take

    def _header(self, out, stamp_ns: int, frame: str):
        out.header.stamp = self._stamp(stamp_ns)
        out.header.frame_id = frame
        return out

    def _pose(self, p: m.Pose):
        out = self._header(self._types[0](), p.stamp_ns, "/map")
        out.pose.position.x, out.pose.position.y, out.pose.position.z = p.x, p.y, p.z
        q = out.pose.orientation
        q.x, q.y, q.z, q.w = (float(v) for v in quaternion_from_euler(p.roll, p.pitch, p.yaw))
        return out

    def _velocity(self, v: m.Velocity):
        out = self._header(self._types[1](), v.stamp_ns, self.car)
        lin, ang = out.twist.linear, out.twist.angular
        lin.x, lin.y, lin.z = v.vx_world, v.vy_world, v.vz_world
        ang.x, ang.y, ang.z = v.wx, v.wy, v.wz
        return out

    def _imu(self, i: m.Imu):
        out = self._header(self._types[2](), i.stamp_ns, self.car)
        o = out.orientation
        o.x, o.y, o.z, o.w = i.qx, i.qy, i.qz, i.qw
        w, a = out.angular_velocity, out.linear_acceleration
        w.x, w.y, w.z = i.wx, i.wy, i.wz
        a.x, a.y, a.z = i.ax, i.ay, i.az
        return out

    def _gps(self, g: m.GpsFix):
        out = self._header(self._types[3](), g.stamp_ns, "gps")
        out.status.status, out.status.service = self._types[4].STATUS_FIX, self._types[4].SERVICE_GPS
        out.latitude, out.longitude, out.altitude = g.latitude, g.longitude, g.altitude
        out.position_covariance_type = 0
        return out

    def _wheel_speed(self, w: m.WheelSpeeds):
        out = self._types[5]()
        out.layout.dim = [self._types[6](label="fl,fr,rl,rr [rad/s]", size=4, stride=4)]
        out.data = [w.fl, w.fr, w.rl, w.rr]
        return out

    def _command(self, raw) -> None:
        try:
            d = command_numbers(raw._buff, raw._connection_header)
        except CommandMessageError as e:
            self._warnings.warning(e.cause, "%s %s; dropped", self.cmd_topic, e)
            return
        with self._lock:
            stamp = self._stamp_ns
        # autonomous: each command lasts until the watchdog's timeout, as the self-driver's on the bus
        cmd = m.ActuatorCommand(stamp_ns=stamp, steer=d[0], longitudinal=m.Longitudinal.FORCE, drive=d[1],
                                brake=d[2], velocity_limit=d[3] if len(d) > 3 else math.inf, autonomous=True)
        self.bus.publish(topic("cmd", self.car), cmd)
        self.commands += 1

    def close(self) -> None:
        """Stop publishing and taking commands; closing again does nothing."""
        for s in self._subs:
            s.close()
        self._cmd_sub.unregister()
        for p in self._pubs.values():
            p.unregister()


def init_node(name: str = "vilma_bridge") -> None:
    """``rospy.init_node`` without rospy's signal handlers (vilma's programs handle SIGINT and SIGTERM), vilma's
    log still going where it went (rospy's logging configuration leaves the root logger only its log file)."""
    import rospy

    root = logging.getLogger()
    handlers, level = root.handlers[:], root.getEffectiveLevel()
    rospy.init_node(name, anonymous=False, disable_signals=True)
    for h in handlers:
        if h not in root.handlers:
            h.setLevel(max(h.level, level))
            logging.getLogger("vilma").addHandler(h)


def shutdown_node(reason: str = "vilma ros1-bridge stopped") -> None:
    """``rospy.signal_shutdown``, waiting (up to :data:`SHUTDOWN_TIMEOUT`) only for its hooks: unregistering
    from the master and closing the node's servers. What rospy does after them, joining a registration thread
    that polls every 0.5 s and sleeping 0.1 s, is left to its daemon thread, so that SIGINT stops the bridge
    within a second."""
    import rospy.core

    hooks_ran = threading.Event()
    rospy.core.add_shutdown_hook(lambda _reason: hooks_ran.set())  # runs after rospy's own hooks
    threading.Thread(target=rospy.core.signal_shutdown, args=(reason,), daemon=True).start()
    hooks_ran.wait(SHUTDOWN_TIMEOUT)
