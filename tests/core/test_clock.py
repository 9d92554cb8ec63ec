import pytest

from vilma.core.clock import Clock, RateError, seconds_to_ns


def test_time_is_integer_ticks_times_step():
    c = Clock(5_000_000)
    c.tick = 3
    assert c.time_ns == 15_000_000
    assert c.time_s == pytest.approx(0.015)
    assert c.ticks_for(1.0) == 200


@pytest.mark.parametrize(("rate", "ticks"), [(200, 1), (100, 2), (50, 4), (10, 20), (4, 50), (1, 200)])
def test_period_ticks_of_whole_multiples(rate, ticks):
    assert Clock(5_000_000).period_ticks(rate, "x") == ticks


def test_rate_not_a_multiple_names_it_and_suggests_rates():
    with pytest.raises(RateError) as e:
        Clock(5_000_000).period_ticks(30, "sensor 'gps'")
    msg = str(e.value)
    assert "sensor 'gps'" in msg and "30 Hz" in msg and "5 ms" in msg
    assert "28.5714 Hz" in msg and "33.3333 Hz" in msg


@pytest.mark.parametrize("rate", [0, -1, float("nan"), float("inf"), 400, "10"])
def test_bad_rates_rejected(rate):
    with pytest.raises(RateError):
        Clock(5_000_000).period_ticks(rate, "x")


@pytest.mark.parametrize("step", [0, -1, 0.005, 1.5])
def test_bad_step_rejected(step):
    with pytest.raises(RateError):
        Clock(step)


def test_seconds_to_ns_rejects_nan():
    with pytest.raises(ValueError):
        seconds_to_ns(float("nan"))
    assert seconds_to_ns(0.25) == 250_000_000


def test_times_beyond_the_int64_clock_are_refused():
    assert seconds_to_ns(9e9) == 9 * 10**18  # 285 years: still counted
    for t in (1e10, -1e10, 1e300):  # past 2^63 ns
        with pytest.raises(ValueError, match="within"):
            seconds_to_ns(t)
    with pytest.raises(RateError, match="x: 1e-10 Hz is a period longer than the clock counts"):
        Clock(5_000_000).period_ticks(1e-10, "x")
