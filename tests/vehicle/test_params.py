import dataclasses
import math
import re

import pytest

from vilma.vehicle.params import GRAVITY, LIMITS, PRESETS, bmw_320i, plant_consts, preset, vilma


def test_vilma_preset_is_the_papers_car():
    p = vilma()
    assert p.mass == 1211.0
    assert (p.cg_to_front, p.cg_to_rear) == (1.1, 1.35)
    assert p.wheelbase == pytest.approx(2.45)
    assert p.track == pytest.approx(1.57)
    assert p.wheel_radius == 0.4
    assert p.max_steer == 0.6
    assert p.drive_split_front == 0.5  # engine force on all four wheels


def test_bmw_is_commonroad_vehicle_2():
    p = bmw_320i()
    # parameters_vehicle2: m = 74.91452 lb s^2/ft, a = 3.793293 ft, b = 4.667707 ft
    assert p.mass == pytest.approx(74.91452 * 14.5939029, rel=1e-4)
    assert p.cg_to_front == pytest.approx(3.793293 * 0.3048, rel=1e-3)
    assert p.cg_to_rear == pytest.approx(4.667707 * 0.3048, rel=1e-3)
    assert p.cornering_stiffness_front / p.load_front == pytest.approx(20.89)
    assert p.max_power == pytest.approx(p.mass * 11.5 * 7.319)


def test_the_outline_is_the_3d_bodys_for_vilma_and_commonroads_for_the_bmw():
    from vilma.plant3d.car_model import BODY_LENGTH_OVERHANG

    p = vilma()
    body = (p.wheelbase + BODY_LENGTH_OVERHANG, p.track + p.suspension.wheel_width)
    assert (p.length, p.width) == pytest.approx(body)
    assert p.body_offset == pytest.approx(-0.125)  # midway between axles 1.1 m ahead and 1.35 m behind
    assert (bmw_320i().length, bmw_320i().width) == (4.508, 1.610)  # parameters_vehicle2: l, w


@pytest.mark.parametrize("field", ["length", "width"])
def test_a_body_without_size_is_refused(field):
    with pytest.raises(ValueError, match=f"vehicle 'vilma': {field} must be > 0"):
        dataclasses.replace(vilma(), **{field: 0.0})


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_axle_loads_sum_to_weight(name):
    p = preset(name)
    assert p.load_front + p.load_rear == pytest.approx(p.mass * GRAVITY)
    assert len(plant_consts(p)) == len(plant_consts(p)._fields)


def test_vilma_understeers_moderately():
    k = vilma().understeer_gradient
    deg_per_g = math.degrees(k) * GRAVITY
    assert 1.0 < deg_per_g < 4.0  # typical passenger cars: 1 to 4 deg/g


def test_equal_normalised_stiffness_is_neutral():
    assert bmw_320i().understeer_gradient == pytest.approx(0.0, abs=1e-12)


def test_unknown_preset_lists_known_ones():
    with pytest.raises(ValueError, match="bmw_320i, vilma"):
        preset("trabant")


@pytest.mark.parametrize(("field", "value"), [("mass", 0.0), ("mass", float("nan")), ("max_steer", 2.0),
                                              ("blend_speed_low", 5.0), ("wheel_radius", -0.3)])
def test_bad_parameters_are_rejected(field, value):
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(vilma(), **{field: value})


def test_params_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        vilma().mass = 1.0


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_top_speed_is_where_full_power_meets_the_resistance(name):
    p = preset(name)
    assert p.resistance(p.top_speed) * p.top_speed == pytest.approx(p.max_power, rel=1e-12)
    no_drag = dataclasses.replace(p, drag_area=0.0)  # rolling resistance alone: P = f v
    assert no_drag.top_speed == pytest.approx(p.max_power / (p.rolling_resistance * p.mass * GRAVITY))
    assert dataclasses.replace(no_drag, rolling_resistance=0.0).top_speed == math.inf


@pytest.mark.parametrize(("field", "value"), [("mass", 1e300), ("mass", 0.01), ("drag_area", 1e-300),
                                              ("max_power", 1e300), ("friction", 1e300), ("drive_split_front", 7.0),
                                              ("tyre_curvature", 2.0), ("wheel_radius", 1e5)])
def test_absurd_parameters_are_refused_with_their_range(field, value):
    low, high = LIMITS[field]
    with pytest.raises(ValueError, match=re.escape(f"vehicle 'vilma': {field} must be within [{low:g}, {high:g}]")):
        dataclasses.replace(vilma(), **{field: value})


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_the_derived_values_are_finite_at_every_corner_of_the_limits(name):
    # the extremes that drive the top speed's Cardano terms: the heaviest, most resisted, least dragged car and the
    # most powerful, least dragged one; each its top speed where full power meets the resistance
    light, heavy = {k: lo for k, (lo, _) in LIMITS.items()}, {k: hi for k, (_, hi) in LIMITS.items()}
    for corner in ({"mass": heavy["mass"], "rolling_resistance": heavy["rolling_resistance"]},
                   {"max_power": heavy["max_power"]}, {"mass": light["mass"]}):
        p = dataclasses.replace(preset(name), drag_area=light["drag_area"], air_density=light["air_density"],
                                **corner)
        v = p.top_speed
        assert math.isfinite(v) and p.load_front > 0 and math.isfinite(p.understeer_gradient)
        assert p.resistance(v) * v == pytest.approx(p.max_power, rel=1e-12)
