"""A CommonRoad road and its traffic in the 3D plant: the lanelets' meshes on their boundaries, the markings where
the pinhole model puts them in a camera image, and the traffic where its recording says, for the laser and for
collisions."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from tests.plant3d.test_camera import project, rgb
from tests.plant3d.test_laser import mount
from vilma.plant3d.camera import CameraParams, CameraSensor
from vilma.plant3d.car_model import BODY_LENGTH_OVERHANG
from vilma.plant3d.laser import LaserParams, LaserSensor
from vilma.plant3d.plant import MujocoPlant
from vilma.plant3d.road import DASH, GAP, MARK_WIDTH, MARK_Z, ROAD_Z, TRAFFIC_HEIGHT, road_xml
from vilma.scenario import load_scenario
from vilma.sim import Simulator
from vilma.vehicle.params import vilma
from vilma.vehicle.state import VehicleState
from vilma.world.commonroad import load
from vilma.world.road_view import LaneletLines
from vilma.world.traffic import Traffic

CAR = vilma()
LANE = 3.5
"""Lane width of the straight test road [m]."""
LENGTH, WIDTH = 4.5, 2.0
"""A traffic car's footprint [m]."""


def straight(length: float = 60.0, left_dashed: bool = False) -> LaneletLines:
    """A lane along x from -10 m, centred on y = 0."""
    x = np.linspace(-10.0, length - 10.0, 7)
    return LaneletLines(1, np.column_stack([x, np.full(7, LANE / 2)]), np.column_stack([x, np.full(7, -LANE / 2)]),
                        left_dashed, False)


def arc() -> LaneletLines:
    """A quarter turn left of radius 20 m (centre line), a lane wide, 9 vertices a side."""
    a = np.linspace(-math.pi / 2, 0.0, 9)
    ring = lambda r: np.column_stack([r * np.cos(a), 20.0 + r * np.sin(a)])  # noqa: E731
    return LaneletLines(7, ring(20.0 - LANE / 2), ring(20.0 + LANE / 2), False, True)


def one_car(x: np.ndarray, y: np.ndarray, yaw: float = 0.0, dt: float = 0.1) -> Traffic:
    """Obstacle 42, a car of :data:`LENGTH` x :data:`WIDTH` recorded at ``x``, ``y`` [m] every ``dt`` [s]."""
    k = len(x)
    outline = np.array([[[-LENGTH / 2, -WIDTH / 2], [LENGTH / 2, -WIDTH / 2], [LENGTH / 2, WIDTH / 2],
                         [-LENGTH / 2, WIDTH / 2]]])
    states = np.zeros((1, k, 4))
    states[0, :, 0], states[0, :, 1], states[0, :, 2] = x, y, yaw
    return Traffic(ids=np.array([42]), static=np.array([k == 1]), outline=outline, states=states,
                   present=np.ones((1, k), bool), dt=dt)


def world_vertices(plant: MujocoPlant, geom: str) -> np.ndarray:
    """The vertices of a mesh geom in the world frame [m] (MuJoCo re-centres a mesh on its own frame)."""
    m, d = plant.model, plant.data
    g = m.geom(geom)
    mesh = m.mesh(g.dataid[0])
    local = m.mesh_vert[mesh.vertadr[0]:mesh.vertadr[0] + mesh.vertnum[0]]
    return local @ d.geom_xmat[g.id].reshape(3, 3).T + d.geom_xpos[g.id]


def test_a_lanelets_mesh_has_its_boundaries_as_vertices_and_covers_its_outline():
    lane = arc()
    plant = MujocoPlant(CAR, road=(lane,))
    vertices = world_vertices(plant, "lanelet7")
    assert vertices[:, :2] == pytest.approx(np.vstack([lane.left, lane.right]), abs=1e-5)
    assert vertices[:, 2] == pytest.approx(ROAD_Z, abs=1e-6)
    m = plant.model
    mesh = m.mesh(m.geom("lanelet7").dataid[0])
    faces = m.mesh_face[mesh.faceadr[0]:mesh.faceadr[0] + mesh.facenum[0]]
    a, b, c = (vertices[faces[:, i], :2] for i in range(3))
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert (cross > 0).all()  # every triangle faces up, to the cameras
    assert cross.sum() / 2 == pytest.approx(shapely.Polygon(lane.surface).area, rel=1e-6)


def test_a_solid_marking_is_a_box_a_segment_on_the_boundary():
    lane = straight()
    plant = MujocoPlant(CAR, road=(lane,))
    m = plant.model
    marks = [m.geom(f"marking{k}") for k in range(12)]  # two solid boundaries of 6 segments
    with pytest.raises(KeyError):
        m.geom("marking12")
    mids = (np.vstack([lane.left[:-1], lane.right[:-1]]) + np.vstack([lane.left[1:], lane.right[1:]])) / 2
    assert np.array([g.pos[:2] for g in marks]) == pytest.approx(mids)
    seg = np.diff(lane.left[:, 0])[0]
    assert np.array([g.size for g in marks]) == pytest.approx(np.tile([seg / 2, MARK_WIDTH / 2, MARK_Z / 2],
                                                                     (12, 1)))


def test_a_dashed_marking_is_dash_on_gap_off_and_a_shared_boundary_is_marked_once():
    lane = straight(length=20.0, left_dashed=True)
    beside = LaneletLines(2, lane.left + np.array([0.0, LANE]), lane.left, False, True)  # its right is our left
    _, xml = road_xml((lane, beside))
    plant = MujocoPlant(CAR, road=(lane, beside))
    m = plant.model
    n = xml.count('name="marking')
    ys = np.array([m.geom(f"marking{k}").pos[1] for k in range(n)])
    dashes = [m.geom(f"marking{k}") for k in np.flatnonzero(ys == LANE / 2)]
    # 20 m: dashes on [0, 3], [9, 12] and [18, 20] m from the start, cut at the segments' ends
    covered = sorted((g.pos[0] - g.size[0], g.pos[0] + g.size[0]) for g in dashes)
    merged = []
    for lo, hi in covered:
        if merged and lo <= merged[-1][1] + 1e-9:
            merged[-1][1] = hi
        else:
            merged.append([lo, hi])
    assert np.array(merged) == pytest.approx(np.array([[-10.0, -10 + DASH], [-10 + DASH + GAP, -10 + 2 * DASH + GAP],
                                                       [-10 + 2 * (DASH + GAP), 10.0]]))
    assert np.count_nonzero(ys == -LANE / 2) == 6 and np.count_nonzero(ys == 1.5 * LANE) == 6


def test_the_front_camera_sees_the_marking_where_the_pinhole_model_puts_it():
    params = CameraParams(pitch=0.15)
    sensor = CameraSensor(params)
    plant = MujocoPlant(CAR, cameras=sensor.mjcf(), road=(straight(),))
    sensor.attach(plant)
    try:
        image = rgb(sensor.capture(0), "front").astype(int)
    finally:
        sensor.close()
    for x in (8.0, 15.0):
        col, row, _ = project(params, (x, LANE / 2, MARK_Z))
        marking = image[round(row), round(col)]
        col, row, _ = project(params, (x, 0.0, ROAD_Z))
        road = image[round(row), round(col)]
        col, row, _ = project(params, (x, LANE / 2 + 1.0, 0.0))
        grass = image[round(row), round(col)]
        assert marking.min() > 180 and np.ptp(marking) < 20  # white
        assert road.max() < 110 and np.ptp(road) < 20  # dark grey
        assert grass[1] > grass[0]  # the ground beside the road is green, as before


def test_the_laser_sees_a_recorded_car_where_the_traffic_is_at_the_sim_time():
    # the car at (5, 3) heading 0.3 rad; the other drives along that heading, 20 m then 10 m ahead over 1 s
    heading = np.array([math.cos(0.3), math.sin(0.3)])
    params = LaserParams()
    sensor = LaserSensor(params)
    ahead = np.array([20.0, 10.0])[:, None]
    path = np.array([5.0, 3.0]) + ahead * heading
    plant = MujocoPlant(CAR, cameras=sensor.mjcf(), traffic=one_car(path[:, 0], path[:, 1], 0.3, dt=1.0),
                        traffic_t0=0.0)
    plant.reset(VehicleState(x=5.0, y=3.0, yaw=0.3))
    sensor.attach(plant)
    assert mount(params)[2] < TRAFFIC_HEIGHT  # the scan plane cuts the body
    try:
        for t, centre in ((0.0, 20.0), (0.5, 15.0)):
            while plant.data.time < t - 1e-9:
                plant.step(0.0, 0.0, 5000.0, 0.01)
            ranges = np.frombuffer(sensor.capture(0)["laser"].ranges, "<f4")
            travelled = (np.array(plant.planar_state()[:2]) - (5.0, 3.0)) @ heading
            assert ranges[len(ranges) // 2] == pytest.approx(centre - LENGTH / 2 - mount(params)[0] - travelled,
                                                             abs=0.01)
    finally:
        sensor.close()


def test_a_recorded_car_that_drives_into_the_car_is_one_collision_named_after_it():
    x = np.linspace(12.0, -8.0, 21)  # 10 m/s toward the car at the origin, through it
    plant = MujocoPlant(CAR, traffic=one_car(x, np.zeros(21)), traffic_t0=0.0)
    front = (CAR.cg_to_front - CAR.cg_to_rear) / 2 + (CAR.wheelbase + BODY_LENGTH_OVERHANG) / 2  # the body's [m]
    before = (12.0 - LENGTH / 2 - front) / 10.0 - 0.05  # [s]
    while plant.data.time < before:
        plant.step(0.0, 0.0, 0.0, 0.01)
    assert plant.collisions == 0
    for _ in range(100):
        plant.step(0.0, 0.0, 0.0, 0.01)
    assert (plant.collisions, plant.last_collision) == (1, "traffic42")


def test_a_car_is_out_of_sight_until_its_recording_starts():
    traffic = one_car(np.full(3, 10.0), np.zeros(3), dt=1.0)
    traffic = Traffic(ids=traffic.ids, static=traffic.static, outline=traffic.outline, states=traffic.states,
                      present=np.array([[False, True, True]]), dt=1.0)
    params = LaserParams()
    sensor = LaserSensor(params)
    plant = MujocoPlant(CAR, cameras=sensor.mjcf(), traffic=traffic)
    sensor.attach(plant)
    try:
        assert not np.isfinite(np.frombuffer(sensor.capture(0)["laser"].ranges, "<f4")).any()
        while plant.data.time < 1.0 - 1e-9:
            plant.step(0.0, 0.0, 5000.0, 0.01)
        ranges = np.frombuffer(sensor.capture(0)["laser"].ranges, "<f4")
        assert ranges[len(ranges) // 2] == pytest.approx(10.0 - LENGTH / 2 - mount(params)[0], abs=0.01)
    finally:
        sensor.close()


def test_a_commonroad_scenario_on_the_3d_plant_has_its_lanelets_and_traffic_in_the_model():
    s = load_scenario("commonroad_tutorial", overrides={"plant": "mujoco"})
    lanelets = load(s.road.file).network.lanelets.lanelets
    assert sorted(la.id for la in s.sim.road) == sorted(la.lanelet_id for la in lanelets)
    sim = Simulator(s.sim)
    try:
        m = sim._plant3d.model
        for la in lanelets:
            g = m.geom(f"lanelet{la.lanelet_id}")
            assert world_vertices(sim._plant3d, g.name)[:, :2] == pytest.approx(
                np.vstack([la.left_vertices, la.right_vertices]), abs=1e-3)
        assert {m.geom(f"obstacle:traffic{i}").name for i in s.road.traffic.ids} == {
            f"obstacle:traffic{o.obstacle_id}" for o in s.road.scenario.obstacles}
    finally:
        sim.close()
    assert load_scenario("commonroad_tutorial").sim.road == ()  # the single-track world draws nothing
