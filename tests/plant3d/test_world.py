"""The 3D world: ramps and bumps under the tyres, obstacles that count as collisions, and the sensors that see
height, roll and pitch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.plant3d.test_plant import hold_speed
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.perception import SegmentParams, segment
from vilma.plant3d.plant import MujocoPlant
from vilma.plant3d.world import Box, Bump, Cone, Ramp, World
from vilma.scenario import SpecError, load_scenario, to_yaml
from vilma.scenario.runner import run
from vilma.sensors import SensorSuite
from vilma.sensors.imu import ImuParams
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.params import GRAVITY, vilma
from vilma.vehicle.state import VehicleState

CAR = vilma()
EXACT_IMU = ImuParams(accel_noise=0.0, gyro_noise=0.0, accel_bias=0.0, gyro_bias=0.0, orientation_noise=0.0)


def _sim(world: World = World()) -> Simulator:
    return Simulator(SimConfig(model="mujoco", world=world, sensors=SensorSuite(imu=EXACT_IMU)))


def _cruise(sim: Simulator, speed: float, seconds: float) -> list[dict]:
    """Hold ``speed`` [m/s] with a proportional acceleration request; the readings of every 20 ms."""
    out = []
    for _ in range(round(seconds / 0.02)):
        sim.command(ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=2.0 * (speed - sim.state.vx)))
        out.append(sim.advance(2))
    return out


def _series(frames: list[dict], sensor: str, name: str) -> np.ndarray:
    return np.concatenate([f[sensor].field(name) for f in frames if sensor in f])


def test_at_rest_on_flat_ground_the_sensors_read_the_planar_plant_values():
    sim = _sim()
    r = sim.run_for(1.0)
    pose, imu = r["pose"].latest(), r["imu"].latest()
    assert abs(pose.z) < 0.005 and abs(pose.roll) < 1e-3 and abs(pose.pitch) < 1e-3  # z: above the rest height
    assert imu.az == pytest.approx(GRAVITY, abs=0.02) and abs(imu.ax) < 0.02 and abs(imu.ay) < 0.02
    assert sim.status().collisions == 0 and sim.status().last_collision == ""


def test_climbing_a_ramp_pitches_the_nose_up_and_the_accelerometer_feels_the_slope():
    ramp = Ramp(start=(10.0, -2.0), length=10.0, height=0.5, top=20.0, width=8.0)
    sim = _sim(World(ramps=(ramp,)))
    sim.reset(VehicleState(vx=3.0))
    frames = _cruise(sim, 3.0, 16.0)
    x, z = _series(frames, "pose", "x"), _series(frames, "pose", "z")
    pitch = _series(frames, "pose", "pitch")
    # the whole car on the slope: rear axle past its foot, front axle before its top
    on_slope = (x - CAR.cg_to_rear > 11.0) & (x + CAR.cg_to_front < 19.0)
    assert on_slope.sum() > 20
    # pitch is positive nose down, so climbing reads -atan(height / length)
    assert pitch[on_slope] == pytest.approx(-ramp.slope, abs=math.radians(0.3))
    ax = _series(frames, "imu", "ax")
    imu_x = np.interp(np.arange(len(ax)) * 0.01, np.arange(len(x)) * 0.02, x)
    climbing = (imu_x - CAR.cg_to_rear > 11.5) & (imu_x + CAR.cg_to_front < 18.5)
    # at constant speed the specific force along the body is the slope's share of gravity
    assert np.median(ax[climbing]) == pytest.approx(GRAVITY * math.sin(ramp.slope), abs=0.08)
    on_top = (x - CAR.cg_to_rear > 21.0) & (x + CAR.cg_to_front < 39.0)
    assert z[on_top] == pytest.approx(ramp.height, abs=0.02)  # the centre of mass rose by the ramp's height
    gps = frames[-1]["gps"].latest()
    assert gps is not None


def test_a_bump_lifts_the_car_no_higher_than_itself_and_the_suspension_settles():
    bump = Bump(pos=(8.0, 0.0), height=0.08, length=0.6)
    sim = _sim(World(bumps=(bump,)))
    sim.reset(VehicleState(vx=3.0))
    frames = _cruise(sim, 3.0, 8.0)
    z, pitch = _series(frames, "pose", "z"), _series(frames, "pose", "pitch")
    assert 0.01 < z.max() < bump.height  # the springs take part of the wheel's rise
    # front wheel up first: nose up (negative pitch) before nose down
    assert np.argmin(pitch) < np.argmax(pitch)
    assert abs(pitch[-25:]).max() < 2e-3  # two seconds after the rear wheel crossed, the body is level again


def test_driving_into_a_box_is_one_collision_named_on_the_status():
    wall = Box(pos=(12.0, 0.0, 0.75), size=(0.5, 3.0, 0.75), name="wall")
    cone = Cone(pos=(6.0, 4.0))  # beside the path: never touched
    sim = _sim(World(boxes=(wall,), cones=(cone,)))
    sim.reset(VehicleState(vx=3.0))
    _cruise(sim, 3.0, 6.0)
    status = sim.status()
    assert (status.collisions, status.last_collision) == (1, "wall")  # one touch, held: counted once
    assert sim.state.x + CAR.cg_to_front < wall.pos[0] - wall.size[0] + 1.0  # stopped at the wall
    sim.reset(VehicleState())
    assert sim.collisions == (0, "")


def test_hitting_a_cone_counts_it_by_name():
    sim = _sim(World(cones=(Cone(pos=(8.0, 0.0), name="c1"), Cone(pos=(12.0, 0.5)))))
    sim.reset(VehicleState(vx=4.0))
    _cruise(sim, 4.0, 2.5)  # the bumper reaches the first cone, not the second
    assert sim.collisions == (1, "c1")


def test_a_world_needs_the_3d_plant_and_valid_elements():
    with pytest.raises(ValueError, match="ramps or bumps needs the 3D plant"):
        SimConfig(world=World(bumps=(Bump(pos=(1.0, 1.0)),)))
    with pytest.raises(ValueError, match="box size must be a finite number > 0"):
        Box(pos=(0.0, 0.0, 0.0), size=(1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match="ramp height must be a finite number"):
        Ramp(start=(0.0, 0.0), height=math.nan)
    with pytest.raises(ValueError, match="below half its length"):
        Bump(pos=(0.0, 0.0), height=0.4, length=0.6)
    with pytest.raises(ValueError, match="obstacle names must differ"):
        World(boxes=(Box(pos=(0, 0, 0), size=(1, 1, 1), name="a"),), cones=(Cone(pos=(3, 3), name="a"),))


def test_the_plant_counts_each_new_touch():
    plant = MujocoPlant(CAR, World(boxes=(Box(pos=(6.0, 0.0, 0.5), size=(0.3, 2.0, 0.5)),)))
    plant.reset(VehicleState(vx=2.0))
    hold_speed(plant, 0.0, 2.0, 3.0)
    assert (plant.collisions, plant.last_collision) == (1, "box0")
    plant.reset(VehicleState(x=-20.0, vx=2.0))
    assert plant.collisions == 0


def test_a_touch_held_is_one_collision_and_one_after_backing_off_is_another():
    plant = MujocoPlant(CAR, World(boxes=(Box(pos=(6.0, 0.0, 0.5), size=(0.3, 2.0, 0.5)),),
                                   cones=(Cone(pos=(0.0, 5.0)),)))  # a cone on the ground is no collision
    plant.reset(VehicleState(vx=2.0))
    hold_speed(plant, 0.0, 2.0, 4.0)  # pushing against the box for seconds: one touch
    assert (plant.collisions, plant.last_collision) == (1, "box0")
    front = plant.planar_state()[0] + CAR.cg_to_front
    hold_speed(plant, 0.0, -1.0, 2.0)  # off it for well over COLLISION_GAP
    assert plant.planar_state()[0] + CAR.cg_to_front < front - 0.5
    hold_speed(plant, 0.0, 2.0, 3.0)
    assert (plant.collisions, plant.last_collision) == (2, "box0")


def test_a_scenario_places_the_world_and_scores_collisions(tmp_path):
    f = tmp_path / "cone.yaml"
    f.write_text("plant: mujoco\nworld:\n  cones: [{pos: [12, 0], name: c}]\n"
                 "  ramps: [{start: [30, -3], height: 0.2}]\n"
                 "task: {course: [[0, 0], [25, 0]], speed: 3}\nduration: 20\nexpect: {collisions: {max: 0}}\n",
                 encoding="utf-8")
    scenario = load_scenario(f)
    assert scenario.sim.world.cones[0].name == "c" and scenario.sim.world.ramps[0].height == 0.2
    again = tmp_path / "again.yaml"
    again.write_text(to_yaml(scenario), encoding="utf-8")
    assert load_scenario(again).sim.world == scenario.sim.world
    result = run(scenario)
    assert result.metrics["collisions"] == 1  # the cone stands on the course
    assert result.failures == ["collisions: 1 is outside max 0"]


def test_ramps_on_the_planar_plant_are_refused_at_their_line(tmp_path):
    f = tmp_path / "flat.yaml"
    f.write_text("task: {speed: 3}\nworld:\n  ramps: [{start: [12, 0]}]\n", encoding="utf-8")
    with pytest.raises(SpecError, match=r"flat.yaml:2: world: .*ramps or bumps needs the 3D plant"):
        load_scenario(f)
    f.write_text("plant: mujoco\ntask: {speed: 3}\nworld:\n  cones: [{pos: [12, 0], radius: -1}]\n", encoding="utf-8")
    with pytest.raises(SpecError, match=r"flat.yaml:4: world.cones\[0\].radius: cone radius must be a finite "
                                        r"number > 0"):
        load_scenario(f)


# -- flat ground: boxes and cones stand still as the scene sensors' traffic, and the scorecard counts touching them


def _flat(tmp_path, text: str):
    f = tmp_path / "flat.yaml"
    f.write_text(text, encoding="utf-8")
    return load_scenario(f)


def test_on_flat_ground_the_objects_sensor_lists_a_cone_and_a_box_where_they_stand(tmp_path):
    sc = _flat(tmp_path, "task: {speed: 1}\nobjects: {position_noise: 0, speed_noise: 0}\nworld:\n"
                         "  cones: [{pos: [10, 2], radius: 0.2}]\n"
                         "  boxes: [{pos: [-5, 3, 0.5], size: [1, 0.5, 0.5], yaw: 0.3}]\n")
    with Simulator(sc.sim) as sim:
        sim.run_for(1 / sc.sim.objects.rate_hz)
        (_, objects), *_ = sim.take_captures()
    box, cone = sorted(objects.objects, key=lambda o: o.id)  # the boxes first, then the cones
    assert (box.id, cone.id) == (1, 2) and cone.speed == 0 == box.speed
    assert (cone.x, cone.y) == pytest.approx((10.0, 2.0)) and (cone.length, cone.width) == pytest.approx((0.4, 0.4))
    assert (box.x, box.y, box.yaw) == pytest.approx((-5.0, 3.0, 0.3)) and (box.length, box.width) == (2.0, 1.0)


def test_on_flat_ground_the_laser_meets_a_cone_at_its_range_in_one_cluster_the_segmentation_keeps(tmp_path):
    sc = _flat(tmp_path, "task: {speed: 1}\nlaser: {range_noise: 0}\nworld: {cones: [{pos: [5, 0]}]}\n")
    p = sc.sim.laser
    with Simulator(sc.sim) as sim:
        sim.run_for(1 / p.rate_hz)
        (_, scan), *_ = sim.take_captures()
    ranges = np.frombuffer(scan.ranges, "<f4").astype(np.float64)
    ahead = np.argmin(np.abs(p.bearings))
    cone = Cone(pos=(5.0, 0.0))
    assert p.bearings[ahead] == 0 and ranges[ahead] == pytest.approx(5.0 - p.position[0] - cone.radius, abs=1e-5)
    (cluster,) = segment(ranges, p.bearings)
    # the rays within the cone's half-angle asin(r / d) from dead ahead, at the laser's resolution: more than the
    # fewest points a cluster keeps (a cone 5 m away spans 4 degrees)
    spans = np.abs(p.bearings) < math.asin(cone.radius / (5.0 - p.position[0]))
    assert ahead in cluster and len(cluster) >= spans.sum() - 1 >= SegmentParams().min_points


def test_on_flat_ground_driving_into_a_cone_is_a_collision_and_passing_one_is_its_gap(tmp_path):
    course = "task: {course: [[0, 0], [25, 0]], speed: 3}\nduration: 15\nexpect: {collisions: {max: 0}}\n"
    hit = run(_flat(tmp_path, course + "world: {cones: [{pos: [12, 0], name: c}, {pos: [18, 3], name: side}]}\n"))
    assert hit.metrics["collisions"] == 1 and hit.metrics["min_distance_to_traffic_m"] == 0  # c, not side
    assert "collisions: 1 is outside max 0" in hit.failures and not hit.metrics["completed"]
    assert hit.metrics["incomplete_reason"].startswith("collided with c (first at ")
    passed = run(_flat(tmp_path, course + "world: {cones: [{pos: [18, 3]}]}\n"))
    gap = 3.0 - CAR.width / 2 - Cone(pos=(0, 0)).radius  # the car on y = 0; the cone's polygon has a vertex at 90 deg
    assert passed.passed and passed.metrics["completed"]
    assert passed.metrics["min_distance_to_traffic_m"] == pytest.approx(gap, abs=0.05)  # and the car's lateral error


@pytest.mark.parametrize(("world", "message"), [
    ("{cones: [{pos: [.nan, 0]}]}", "world.cones[0].pos[0]: expected a finite number, got nan"),
    ("{cones: [{radius: 0.2}]}", "world.cones[0]: missing pos"),
    ("{boxes: [{pos: [1, 2, .inf], size: [1, 1, 1]}]}", "world.boxes[0].pos[2]: expected a finite number, got inf"),
])
def test_a_bad_obstacle_on_flat_ground_is_one_line_naming_its_field(tmp_path, world, message):
    with pytest.raises(SpecError) as e:
        _flat(tmp_path, f"task: {{speed: 3}}\nworld: {world}\n")
    assert str(e.value) == f"{tmp_path / 'flat.yaml'}:2: {message}"


def test_obstacles_on_flat_ground_with_a_commonroad_world_are_refused(tmp_path):
    from tests.scenario.test_planned import TUTORIAL

    with pytest.raises(SpecError, match=r"flat.yaml:1: world: boxes and cones on flat ground go without a CommonRoad"):
        _flat(tmp_path, f"world: {{commonroad: {TUTORIAL}, cones: [{{pos: [1, 2]}}]}}\n")
