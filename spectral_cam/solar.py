"""Where the sun stands: the solar position for a date, clock time and place, and the unit
vector towards it in a scene's frame.

The position follows NOAA's solar calculator (Meeus's low-precision solar coordinates: the
sun's apparent longitude, the obliquity of the ecliptic, the equation of time and the hour
angle), accurate to about 0.01° between 1800 and 2100, plus NOAA's atmospheric-refraction
correction so the elevation is where the sun *appears*. We compute it ourselves and hand
Mitsuba's ``sunsky`` a ``sun_direction`` rather than its date and place: measured on Mitsuba
3.9.1, its own solar azimuth is mirrored east–west against its documentation.

Frames: azimuth is measured from north, clockwise (east = 90°); the local frame is east,
north, up. A preset's camera looks along +z with +y up and +x to the image's left, on a
compass heading (the direction of its view, clockwise from north).

References
----------
.. [1] Meeus, J. (1998). Astronomical Algorithms, 2nd ed., ch. 25 (solar coordinates, low
   accuracy) and ch. 28 (equation of time). Willmann-Bell.
.. [2] NOAA Global Monitoring Laboratory, "General Solar Position Calculations" and the
   NOAA Solar Calculator spreadsheet (refraction after Sæmundsson/Bennett).
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass

import numpy as np

from .errors import ConfigError

__all__ = ["SunPosition", "sun_position", "enu_to_camera", "parse_date"]


@dataclass(frozen=True)
class SunPosition:
    """The sun seen from a place at an instant.

    Attributes
    ----------
    azimuth_deg : float
        Clockwise from north (east = 90°).
    elevation_deg : float
        Apparent elevation above the horizon (refraction included), degrees.
    declination_deg, equation_of_time_min : float
        The intermediate quantities NOAA's calculator reports (for checking).
    """

    azimuth_deg: float
    elevation_deg: float
    declination_deg: float
    equation_of_time_min: float

    @property
    def zenith_deg(self) -> float:
        return 90.0 - self.elevation_deg

    def direction_enu(self) -> np.ndarray:
        """Unit vector towards the sun in (east, north, up)."""
        az, el = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        return np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])


def parse_date(text: str) -> _dt.date:
    """An ISO date ``YYYY-MM-DD``.

    Raises
    ------
    ConfigError
        When ``text`` is not one.
    """
    try:
        return _dt.date.fromisoformat(str(text))
    except ValueError:
        raise ConfigError(f"sky.date = {text!r} is not a date; give it as YYYY-MM-DD, e.g. \"2026-06-21\"") from None


def _julian_day(date: _dt.date, hour_utc: float) -> float:
    """Julian day of a UTC instant (Meeus ch. 7: 2451545.0 is 2000-01-01 12:00 UTC)."""
    days = (date - _dt.date(2000, 1, 1)).days
    return 2451544.5 + days + hour_utc / 24.0


def _refraction_deg(elevation_deg: float) -> float:
    """NOAA's refraction correction (degrees) for a true elevation."""
    e = elevation_deg
    if e > 85.0:
        return 0.0
    t = math.tan(math.radians(e))
    if e > 5.0:
        arcsec = 58.1 / t - 0.07 / t ** 3 + 0.000086 / t ** 5
    elif e > -0.575:
        arcsec = 1735.0 + e * (-518.2 + e * (103.4 + e * (-12.79 + e * 0.711)))
    else:
        arcsec = -20.772 / t
    return arcsec / 3600.0


def sun_position(date: _dt.date | str, hour: float, *, utc_offset_h: float, latitude_deg: float,
                 longitude_deg: float) -> SunPosition:
    """The sun's apparent azimuth and elevation.

    Parameters
    ----------
    date : datetime.date or str
        Local calendar date (``YYYY-MM-DD``).
    hour : float
        Local clock time in hours (14.5 is 14:30).
    utc_offset_h : float
        The clock's offset from UTC in hours (+2 for central European summer time).
    latitude_deg, longitude_deg : float
        North and east positive.

    Returns
    -------
    SunPosition

    References
    ----------
    .. [1] NOAA Global Monitoring Laboratory, "General Solar Position Calculations"; Meeus
       (1998), Astronomical Algorithms, ch. 25 and 28.
    """
    if isinstance(date, str):
        date = parse_date(date)
    jc = (_julian_day(date, hour - utc_offset_h) - 2451545.0) / 36525.0  # Julian centuries since J2000
    mean_longitude = (280.46646 + jc * (36000.76983 + jc * 0.0003032)) % 360.0
    mean_anomaly = 357.52911 + jc * (35999.05029 - 0.0001537 * jc)
    eccentricity = 0.016708634 - jc * (0.000042037 + 0.0000001267 * jc)
    m = math.radians(mean_anomaly)
    centre = (math.sin(m) * (1.914602 - jc * (0.004817 + 0.000014 * jc))
              + math.sin(2 * m) * (0.019993 - 0.000101 * jc) + math.sin(3 * m) * 0.000289)
    omega = math.radians(125.04 - 1934.136 * jc)
    apparent_longitude = mean_longitude + centre - 0.00569 - 0.00478 * math.sin(omega)
    mean_obliquity = 23.0 + (26.0 + (21.448 - jc * (46.815 + jc * (0.00059 - jc * 0.001813))) / 60.0) / 60.0
    obliquity = math.radians(mean_obliquity + 0.00256 * math.cos(omega))
    declination = math.asin(math.sin(obliquity) * math.sin(math.radians(apparent_longitude)))
    y = math.tan(obliquity / 2) ** 2
    l0 = math.radians(mean_longitude)
    equation_of_time = 4.0 * math.degrees(
        y * math.sin(2 * l0) - 2 * eccentricity * math.sin(m) + 4 * eccentricity * y * math.sin(m) * math.cos(2 * l0)
        - 0.5 * y * y * math.sin(4 * l0) - 1.25 * eccentricity ** 2 * math.sin(2 * m))
    true_solar_minutes = (hour * 60.0 + equation_of_time + 4.0 * longitude_deg - 60.0 * utc_offset_h) % 1440.0
    hour_angle = math.radians(true_solar_minutes / 4.0 - 180.0)
    latitude = math.radians(latitude_deg)
    cos_zenith = (math.sin(latitude) * math.sin(declination)
                  + math.cos(latitude) * math.cos(declination) * math.cos(hour_angle))
    zenith = math.acos(min(1.0, max(-1.0, cos_zenith)))
    # azimuth from north, clockwise: atan2 of the east and north components of the direction
    east = -math.cos(declination) * math.sin(hour_angle)
    north = math.cos(latitude) * math.sin(declination) - math.sin(latitude) * math.cos(declination) * math.cos(hour_angle)
    azimuth = math.degrees(math.atan2(east, north)) % 360.0
    elevation = 90.0 - math.degrees(zenith)
    return SunPosition(azimuth, elevation + _refraction_deg(elevation), math.degrees(declination), equation_of_time)


def enu_to_camera(heading_deg: float, pitch_deg: float = 0.0) -> np.ndarray:
    """3×3 matrix taking (east, north, up) vectors into the frame of a camera whose view
    points along compass ``heading_deg`` (clockwise from north), tilted by ``pitch_deg``
    (> 0 up): camera +z is the view, +y up, +x the image's left."""
    h = math.radians(heading_deg)
    forward = np.array([math.sin(h), math.cos(h), 0.0])
    left = np.array([-math.cos(h), math.sin(h), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    level = np.stack([left, up, forward])  # rows: camera axes in ENU
    p = math.radians(pitch_deg)
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(p), -math.sin(p)], [0.0, math.sin(p), math.cos(p)]])
    return tilt @ level
