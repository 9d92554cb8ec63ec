import dataclasses
import logging
import math

import numpy as np
import pytest

from tests.conftest import STEP, physics_only
from vilma.core.clock import RateError
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.sensors import SensorSuite
from vilma.sensors.gps import GpsParams
from vilma.sim import SimConfig, Simulator
from vilma.sim.simulator import KernelResult, PlantKernel
from vilma.vehicle.integrate import advance
from vilma.vehicle.params import vilma
from vilma.vehicle.state import VehicleState

SUITE = SensorSuite()
RATES = {"pose": 50, "velocity": 50, "gps": 10, "imu": 100, "wheel_speed": 50, "odometry": 50, "actuators": 50}


def test_every_sensor_at_its_rate_with_integer_stamps():
    sim = Simulator()
    r = sim.run_for(2.0)
    assert {k: len(v) for k, v in r.items()} == {k: 2 * v for k, v in RATES.items()}
    for name, readings in r.items():
        period = 1_000_000_000 // RATES[name]
        assert readings.stamp_ns.dtype == np.int64
        assert np.array_equal(readings.stamp_ns, period * np.arange(1, 2 * RATES[name] + 1))
        assert readings.latest().stamp_ns == 2_000_000_000


def test_rate_that_is_not_a_multiple_of_the_step_is_an_error():
    config = SimConfig(sensors=dataclasses.replace(SUITE, gps=GpsParams(rate_hz=30.0)))
    with pytest.raises(RateError, match=rf"sensor 'gps'.*30 Hz.*{STEP * 1e3:g} ms"):
        Simulator(config)
    fixed = dataclasses.replace(config, sensors=dataclasses.replace(SUITE, gps=GpsParams(rate_hz=25.0)))
    assert len(Simulator(fixed).run_for(1.0)["gps"]) == 25


def _record(chunks, seed=7, commands=((0.0, ActuatorCommand(steer=0.2, drive=2500.0)),
                                      (3.0, ActuatorCommand(steer=-0.3, longitudinal=Longitudinal.POWER,
                                                            drive=800.0)))):
    sim = Simulator(SimConfig(seed=seed))
    out = {}
    t, pending = 0.0, list(commands)
    for dt in chunks:
        while pending and pending[0][0] <= t + 1e-9:
            sim.command(pending.pop(0)[1])
        for name, r in sim.run_for(dt).items():
            out.setdefault(name, []).append(r.values)
        t += dt
    return sim._z.copy(), {k: np.concatenate(v) for k, v in out.items()}


def test_deterministic_bit_for_bit_however_the_run_is_chunked():
    z1, r1 = _record([3.0, 3.0])
    z2, r2 = _record([STEP] * round(1 / STEP) + [0.25] * 8 + [1.0] * 3)
    z3, r3 = _record([3.0, 3.0])
    assert np.array_equal(z1, z2) and np.array_equal(z1, z3)
    for name in r1:
        assert np.array_equal(r1[name], r2[name]), name
        assert np.array_equal(r1[name], r3[name]), name


def test_another_seed_changes_the_noise_not_the_physics():
    z1, r1 = _record([6.0], seed=1)
    z2, r2 = _record([6.0], seed=2)
    assert np.array_equal(z1, z2)
    assert not np.array_equal(r1["gps"], r2["gps"])
    assert np.array_equal(r1["pose"], r2["pose"])


def test_reset_restarts_time_state_and_noise():
    sim = Simulator()
    sim.command(ActuatorCommand(drive=2000.0))
    first = sim.run_for(1.0)["gps"].values
    sim.reset()
    assert sim.time_ns == 0 and sim.state == VehicleState()
    sim.command(ActuatorCommand(drive=2000.0))
    assert np.array_equal(sim.run_for(1.0)["gps"].values, first)


def test_a_simulator_made_at_a_start_is_one_reset_to_it():
    start = VehicleState(x=3.0, y=-2.0, yaw=0.5, vx=4.0)
    made, reset = Simulator(initial=start), Simulator()
    reset.reset(start)
    assert made.time_ns == 0 and made.state == reset.state and made.state.x == 3.0 and made.state.vx == 4.0
    a, b = made.run_for(1.0), reset.run_for(1.0)
    assert a.keys() == b.keys()
    for name in a:  # the same plant and the same noise: bit for bit
        assert np.array_equal(a[name].values, b[name].values), name


def test_a_command_between_frames_drives_the_frames_after_it_as_it_drives_a_simulator_started_there():
    first = ActuatorCommand(steer=0.05, drive=2500.0)
    then = ActuatorCommand(steer=-0.1, longitudinal=Longitudinal.POWER, drive=0.4)
    sim = Simulator(initial=VehicleState(vx=8.0))  # no dead time: a command acts from the next step
    sim.command(first)
    for _ in range(50):  # frames whose compiled call keeps its arguments
        sim.run_for(0.02)
    there = Simulator(initial=sim.state)
    for s in (sim, there):
        s.command(then)
        for _ in range(50):
            s.run_for(0.02)
    np.testing.assert_allclose(sim.plant, there.plant, rtol=1e-12, atol=1e-12)  # a start's rounding apart
    assert sim.state.vx > 3.0


def test_watchdog_stops_the_car_when_autonomous_commands_stop():
    p = vilma()
    sim = Simulator(physics_only())
    v0 = 15.0
    sim.reset(VehicleState(vx=v0, drive_force=p.resistance(v0)))
    sim.command(ActuatorCommand(longitudinal=Longitudinal.ACCEL, autonomous=True))
    sim.run_for(0.49)
    assert not sim.watchdog_tripped and sim.state.vx == pytest.approx(v0, abs=0.01)
    sim.run_for(0.02)
    assert sim.watchdog_tripped and sim.status().watchdog_tripped
    x_trip = sim.state.x
    sim.run_for(10.0)
    s = sim.state
    assert abs(s.vx) < 0.01
    # controlled stop: v^2 / (2 a) plus about one brake time constant at v0
    a = p.actuators.stop_deceleration
    assert s.x - x_trip == pytest.approx(v0**2 / (2 * a) + v0 * p.actuators.brake_time_constant, rel=0.1)


def test_watchdog_fires_at_the_end_of_the_frame_that_reaches_its_timeout():
    sim = Simulator(physics_only())  # the timeout (0.5 s) is 25 frames of 20 ms: the 25th ends at the deadline
    sim.command(ActuatorCommand(drive=2000.0, autonomous=True))
    frames = round(sim.config.watchdog_timeout / 0.02)
    for _ in range(frames - 1):
        sim.run_for(0.02)
    assert not sim.watchdog_tripped
    sim.run_for(0.02)
    assert sim.watchdog_tripped


def test_run_for_takes_each_time_its_own_seconds():
    sim = Simulator(physics_only())
    for seconds in (0.02, 0.05, 0.05, 0.02, 1.0):
        sim.run_for(seconds)
    assert sim.time_ns == 1_140_000_000
    with pytest.raises(ValueError, match="finite"):
        sim.run_for(math.nan)


def test_watchdog_resumes_when_commands_come_back():
    sim = Simulator(physics_only())
    sim.command(ActuatorCommand(drive=2000.0, autonomous=True))
    sim.run_for(2.0)
    assert sim.watchdog_tripped
    sim.command(ActuatorCommand(drive=2000.0, autonomous=True))
    assert not sim.watchdog_tripped
    v = sim.state.vx
    sim.run_for(0.4)
    assert sim.state.vx > v and not sim.watchdog_tripped


def test_manual_commands_hold_without_watchdog():
    sim = Simulator(physics_only())
    sim.command(ActuatorCommand(drive=2000.0))
    sim.run_for(5.0)
    assert not sim.watchdog_tripped and sim.state.vx > 5.0


def test_clamped_command_is_reported(caplog):
    sim = Simulator(physics_only())
    notes = sim.command(ActuatorCommand(steer=-2.0))
    assert notes and "'steer'" in notes[0] and "'steer'" in caplog.text
    sim.run_for(3.0)
    assert sim.state.steer == pytest.approx(-0.6)


def test_a_flood_of_clamped_commands_is_one_line_a_sim_second(caplog):
    sim = Simulator(physics_only())
    with caplog.at_level(logging.WARNING, logger="vilma.sim.simulator"):
        for _ in range(100):
            sim.command(ActuatorCommand(steer=-2.0, drive=1e9))
        sim.run_for(1.0)
        sim.command(ActuatorCommand(steer=-2.0))
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2 and "'steer'" in lines[0] and "'drive'" in lines[0]  # both fields, one line
    assert lines[1].endswith("(99 more like it in the last 1.0 s not shown)")


def test_status_message():
    sim = Simulator()
    sim.run_for(0.5)
    st = sim.status(real_time_factor=2.0)
    assert st.stamp_ns == 500_000_000 and st.real_time_factor == 2.0 and not st.autonomous
    assert math.isnan(sim.status().real_time_factor)


def test_a_simulator_in_a_with_block_frees_its_renderers_even_when_the_block_raises():
    pytest.importorskip("mujoco")
    from vilma.plant3d.camera import CameraParams

    config = SimConfig(model="mujoco", cameras=(CameraParams(width=32, height=24),))
    with pytest.raises(RuntimeError, match="boom"), Simulator(config) as sim:
        assert isinstance(sim, Simulator)
        camera = sim._world_sensors[0]
        assert camera._gl is not None  # it holds an EGL context
        raise RuntimeError("boom")
    assert camera._gl is None and camera._context is None
    sim.close()  # a second close does nothing


def _integrate(p: PlantKernel) -> KernelResult:
    """A kernel that only integrates the plant, 37 steps at the command in force."""
    m = advance(p.model, p.integrator, p.z, int(p.mode[0]), p.cmd, p.consts, p.step, 37, p.tick, p.periods,
                *p.records)
    return KernelResult(37, m, None)


def test_compiled_code_advances_the_plant_as_advance_does():
    twins = [Simulator(SimConfig()) for _ in range(2)]
    for sim in twins:
        sim.command(ActuatorCommand(steer=0.1, longitudinal=Longitudinal.FORCE, drive=800.0))
        sim.advance(5)
    expected = twins[0].advance(37)
    got = twins[1].advance_compiled(64, _integrate)
    assert twins[1].clock.tick == twins[0].clock.tick == 42
    assert np.array_equal(twins[1].plant, twins[0].plant)
    assert got.keys() == expected.keys()
    for name, readings in expected.items():
        assert np.array_equal(got[name].stamp_ns, readings.stamp_ns)
        assert np.array_equal(got[name].values, readings.values, equal_nan=True), name


def test_compiled_code_without_sensing_advances_the_plant_alike_and_the_sensors_skip_its_steps():
    twins = [Simulator(SimConfig()) for _ in range(2)]
    for sim in twins:
        sim.command(ActuatorCommand(steer=0.1, longitudinal=Longitudinal.FORCE, drive=800.0))
    sensed = twins[0].advance_compiled(64, _integrate)
    k = twins[1].kernel_start(64, sensing=False)
    done = _integrate(k)
    assert sensed and done.records == 0  # nothing recorded for the sensors
    assert twins[1].kernel_end(k, done) == {}
    assert twins[1].clock.tick == twins[0].clock.tick == 37
    assert np.array_equal(twins[1].plant, twins[0].plant)
    fresh = Simulator(SimConfig())  # no noise drawn
    noisy = [i for i, s in enumerate(fresh.sensors) if hasattr(s, "rng")]
    assert len(noisy) > 3
    assert [twins[1].sensors[i].rng.bit_generator.state for i in noisy] == \
        [fresh.sensors[i].rng.bit_generator.state for i in noisy]


def test_compiled_code_may_not_advance_a_car_with_actuator_dead_time():
    v = vilma()
    sim = Simulator(SimConfig(vehicle=dataclasses.replace(v, actuators=dataclasses.replace(v.actuators,
                                                                                          dead_time=0.05))))
    sim.command(ActuatorCommand(drive=1.0))
    with pytest.raises(RuntimeError, match="cannot be advanced by compiled code now"):
        sim.advance_compiled(10, _integrate)


def test_reactive_traffic_steps_with_the_simulator_and_a_reset_restarts_it_at_its_recorded_start(tmp_path):
    """``traffic: reactive``: the simulator drives the IDM traffic as it advances, however the advance is chunked,
    and a reset puts each car back where the file has it at sim time 0, to drive the same again."""
    from tests.scenario.test_reactive_traffic import CAR_SPEED, CAR_X, _scenario
    from vilma.scenario.runner import initial_state, sim_config

    sc = _scenario(tmp_path, "traffic: reactive")
    start, file_start = initial_state(sc, None), sc.sim.traffic.at(sc.sim.traffic_t0)
    with Simulator(sim_config(sc)) as sim:
        traffic = sim.config.traffic
        assert sim.config.reactive is not None and traffic is sim.config.reactive.traffic and traffic.ring
        drives = []
        for chunk in (3.0, 0.13):  # in one go, then in chunks that end between the traffic's periods
            sim.reset(start)
            assert np.array_equal(traffic.at(0.0)[0], file_start[0]) and traffic.at(0.0)[1].all()
            while sim.clock.time_s < 3.0 - 1e-9:
                sim.run_for(min(chunk, 3.0 - sim.clock.time_s))
            drives.append(traffic.at(3.0)[0])
        assert np.array_equal(drives[0], drives[1])
        x = drives[0][0, 0]  # braking behind the ego (which no driver moves), not as recorded
        assert CAR_X < x < CAR_X + CAR_SPEED * 3.0 - 1.0
