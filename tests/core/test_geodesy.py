"""Geodesy against pymap3d, an independent implementation of the same WGS84 formulas."""

import numpy as np
import pymap3d
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from vilma.core.geodesy import EnuFrame, GeodeticOrigin, ecef_to_geodetic, geodetic_to_ecef


@settings(max_examples=2000)
@example(52.70176826462895, 0.0, 0.0)  # where math.hypot is not numpy's (pymap3d's)
@given(st.floats(-90.0, 90.0), st.floats(-180.0, 180.0), st.floats(-500.0, 9000.0))
def test_geodetic_to_ecef_is_pymap3ds_to_the_bit(lat, lon, h):
    """The GPS origin's ECEF point was pymap3d's: a run's readings stay the same bits."""
    assert geodetic_to_ecef(lat, lon, h) == pymap3d.geodetic2ecef(lat, lon, h)


@pytest.mark.parametrize(("lat", "lon", "h"), [(-22.8195, -47.0663, 600.0), (89.9, 10.0, 0.0), (0.0, 179.9, -50.0),
                                               (45.0, -120.0, 8000.0)])
def test_ecef_to_geodetic_inverts_pymap3ds_geodetic2ecef(lat, lon, h):
    out = ecef_to_geodetic(*pymap3d.geodetic2ecef(lat, lon, h))
    assert out == pytest.approx((lat, lon, h), abs=1e-7)


def test_enu_points_go_where_pymap3d_puts_them():
    o = GeodeticOrigin()
    enu = np.array([[0.0, 0.0, 0.0], [1000.0, -250.0, 3.0], [-5e4, 2e4, 100.0]])
    expected = np.array(pymap3d.enu2geodetic(enu[:, 0], enu[:, 1], enu[:, 2], o.latitude, o.longitude,
                                             o.altitude)).T
    np.testing.assert_allclose(EnuFrame(o).to_geodetic(enu), expected, rtol=0, atol=1e-6)


def test_an_origin_off_the_globe_is_refused():
    with pytest.raises(ValueError, match="not a valid lat/lon"):
        GeodeticOrigin(latitude=91.0)
