"""The sensor bank against the definition of each sensor's readings: the sensor's own ``measure``."""

import pickle

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.core.messages import Pose
from vilma.sensors import Samples, SensorSuite, build_sensors
from vilma.sensors.bank import BLOCK, FIRST_AHEAD, MAX_NORMALS, SensorBank, as_rows
from vilma.sensors.base import NO_3D, Readings, rows_of, sensor_rng
from vilma.sensors.gps import GpsParams
from vilma.sensors.imu import ImuParams
from vilma.sensors.pose import PoseParams
from vilma.sensors.velocity import VelocityParams
from vilma.vehicle.params import vilma
from vilma.vehicle.state import N3, NX, NZ

STEP_NS = 10_000_000
NOISY = SensorSuite(pose=PoseParams(position_noise=0.1, yaw_noise=0.01),
                    velocity=VelocityParams(rate_hz=25.0, linear_noise=0.1, angular_noise=0.01),
                    gps=GpsParams(rate_hz=1.0, bias_sigma=0.3, offset=(0.5, 0.2, 1.5)),
                    imu=ImuParams(offset=(0.3, -0.1, 0.2)))
"""Every sensor, each with noise (GPS and IMU with drifting biases), at rates from 1 to 100 Hz."""
PERIODS = np.array([5, 4, 100, 1, 2, 2, 2], dtype=np.int64)  # ticks of 10 ms: 20, 25, 1, 100, 50, 50, 50 Hz


def _plant(steps, seed=0):
    """A made-up plant record for ticks 1 .. steps, with the 3D plant's: any numbers will do, the bank must read them
    as the sensors do."""
    rng = np.random.default_rng(seed)
    return (rng.normal(size=(steps, NZ)) * 3.0, rng.normal(size=(steps, NX)), np.arange(1, steps + 1, dtype=np.int64),
            rng.normal(size=(steps, N3)))


def _sensors(seed=4):
    sensors = build_sensors(NOISY, vilma())
    z0 = _plant(1, seed=1)[0][0]
    for s in sensors:
        s.reset(z0, sensor_rng(seed, s.name))
    return sensors


def _own(steps, plant3d=False):
    """Each sensor's readings of ticks 1 .. steps by its own ``measure``, in one batch: (stamps, values) by name."""
    z, dx, ticks, extra = _plant(steps)
    extra, out = extra if plant3d else NO_3D, {}
    for sensor, period in zip(_sensors(), PERIODS.tolist(), strict=True):
        count = steps // period
        stamps = np.arange(period, (count + 1) * period, period, dtype=np.int64) * STEP_NS
        out[sensor.name] = stamps, sensor.measure(Samples(rows_of(ticks, period, count), z, dx, extra))
    return out


def _banked(chunks, plant3d=False):
    """The bank's readings of ticks 1 .. sum(chunks), measured chunk by chunk: lists of Readings by name."""
    z, dx, ticks, extra = _plant(sum(chunks))
    extra, bank, t0, got = extra if plant3d else NO_3D, SensorBank(_sensors(), PERIODS, plant3d), 0, {}
    bank.reset()
    for n in chunks:
        rows = slice(t0, t0 + n)  # the records of this chunk alone, as the simulator hands them over (none: NO_3D's)
        for name, r in bank.measure(t0, n, ticks[rows], z[rows], dx[rows], STEP_NS, extra[rows]).items():
            got.setdefault(name, []).append(r)
        t0 += n
    return got


@settings(max_examples=25, deadline=None)
@given(st.lists(st.one_of(st.integers(1, 7), st.integers(BLOCK - 3, 3 * BLOCK)), min_size=1, max_size=12),
       st.booleans())
def test_the_bank_reads_bit_for_bit_what_each_sensor_measures_however_the_run_is_chunked_on_either_plant(chunks,
                                                                                                         plant3d):
    own, got = _own(sum(chunks), plant3d), _banked(chunks, plant3d)
    assert set(got) == {name for name, (stamps, _) in own.items() if len(stamps)}
    for name, parts in got.items():
        stamps, values = own[name]
        np.testing.assert_array_equal(np.concatenate([r.stamp_ns for r in parts]), stamps)
        np.testing.assert_array_equal(np.concatenate([r.values for r in parts]), values)


def test_readings_handed_out_stay_as_they_were_while_the_bank_goes_on():
    steps = 4 * BLOCK  # the IMU fills a block every BLOCK steps: new blocks and fresh noise come meanwhile
    z, dx, ticks, _ = _plant(steps)
    bank = SensorBank(_sensors(), PERIODS)
    bank.reset()
    kept = [(r, r.stamp_ns.copy(), r.values.copy()) for r in bank.measure(0, 2, ticks[:2], z[:2], dx[:2],
                                                                        STEP_NS).values()]
    for t0 in range(2, steps, 2):
        bank.measure(t0, 2, ticks[t0:t0 + 2], z[t0:t0 + 2], dx[t0:t0 + 2], STEP_NS)
    for r, stamps, values in kept:
        np.testing.assert_array_equal(r.stamp_ns, stamps)
        np.testing.assert_array_equal(r.values, values)


def test_noise_drawn_ahead_stays_within_two_blocks_with_sensors_a_hundred_times_apart():
    """A 1 Hz GPS uses its noise a hundred times slower than a 100 Hz IMU: each stream is topped up to a block ahead
    when room is made, never past it, so what is held ahead does not pile up."""
    steps = 60 * BLOCK
    z, dx, ticks, _ = _plant(2)
    bank = SensorBank(_sensors(), PERIODS)
    bank.reset()
    largest = 0
    for t0 in range(0, steps, 2):
        ticks[:] = t0 + 1, t0 + 2
        bank.measure(t0, 2, ticks, z, dx, STEP_NS)
        largest = max(largest, bank.noise.shape[1] // MAX_NORMALS)
    assert largest <= 2 * BLOCK


def test_a_bank_that_measures_once_draws_little_noise():
    """A compiled run whose readings nobody takes measures its first period only: its sensors draw the noise of
    FIRST_AHEAD samples, not of a block (the draws then double up to a block; the readings are the same numbers
    however they are drawn, as the test above checks)."""
    z, dx, ticks, _ = _plant(2)
    sensors = _sensors()
    bank = SensorBank(sensors, PERIODS)
    bank.reset()
    bank.measure(0, 2, ticks, z, dx, STEP_NS)
    imu, twin = (next(s for s in group if s.name == "imu") for group in (sensors, _sensors()))
    twin.rng.standard_normal(FIRST_AHEAD * 13)  # the IMU's 13 normals a sample
    assert FIRST_AHEAD < BLOCK and imu.rng.bit_generator.state == twin.rng.bit_generator.state


def test_the_normals_ahead_are_those_a_sensor_takes_next_and_stay_its_own():
    steps = 40  # the IMU has taken 40 rows of its 13 normals a sample; ask past what is drawn ahead
    z, dx, ticks, _ = _plant(steps + 2 * BLOCK)
    sensors = _sensors()
    bank = SensorBank(sensors, PERIODS)
    bank.reset()
    bank.measure(0, steps, ticks[:steps], z[:steps], dx[:steps], STEP_NS)
    imu = next(s for s in sensors if s.name == "imu")
    twin = next(s for s in _sensors() if s.name == "imu")
    ahead = bank.normals_ahead(imu, 2 * BLOCK)
    np.testing.assert_array_equal(ahead, twin.rng.standard_normal((steps + 2 * BLOCK, 13))[steps:])
    rest = slice(steps, steps + 2 * BLOCK)
    later = bank.measure(steps, 2 * BLOCK, ticks[rest], z[rest], dx[rest], STEP_NS)
    own = _own(steps + 2 * BLOCK)["imu"][1][steps:]
    np.testing.assert_array_equal(later["imu"].values, own)


def test_readings_of_rows_of_a_block_are_those_rows_and_pickle_only_them():
    stamps, values = np.arange(BLOCK, dtype=np.int64) * STEP_NS, np.arange(BLOCK * 6.0).reshape(BLOCK, 6)
    r = Readings("pose", Pose, stamps, values, 3, 5)
    assert len(r) == 2 and repr(r) == "Readings('pose', Pose, 2 readings)"
    np.testing.assert_array_equal(r.stamp_ns, stamps[3:5])
    np.testing.assert_array_equal(r.values, values[3:5])
    assert r.messages() == [Pose(int(stamps[i]), *values[i].tolist()) for i in (3, 4)]
    back = pickle.loads(pickle.dumps(r))  # as a recorder process gets them
    assert (back.name, back.message, len(back)) == ("pose", Pose, 2)
    np.testing.assert_array_equal(back.values, values[3:5])
    assert len(pickle.dumps(r)) < values.nbytes // 10  # two rows of 512, not the block


@settings(deadline=None)  # the first example compiles
@given(st.integers(0, 5), st.integers(0, 4), st.integers(0, 13))
def test_as_rows_is_the_reshape_of_those_rows(first, n, width):
    flat = np.arange(200.0)
    expected = flat[first * width:(first + n) * width].reshape(n, width)
    rows = as_rows(flat, first, n, width)
    assert rows.shape == expected.shape and np.array_equal(rows, expected)
    rows[...] = -1.0  # a view: written through to ``flat``
    assert (flat[first * width:(first + n) * width] == -1.0).all()
