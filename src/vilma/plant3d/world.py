"""The world the 3D car drives in: flat ground, ramps and bumps to drive over, boxes and cones to avoid.

Placed in the ENU world frame [m, rad]. Ramps and bumps touch only the tyres; obstacles (boxes, cones) touch
the tyres and the car's body, and a touch is a collision (:class:`~vilma.plant3d.plant.MujocoPlant` counts
them). Boxes stand fixed, like walls; cones are loose and fall over. On flat ground (the single-track plant) both
are obstacles standing still (:meth:`World.traffic`). Each element validates itself when made, so a bad scenario
entry fails with the field at fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vilma.core.checks import check_numbers
from vilma.world.traffic import Traffic

SLAB = 0.2
"""Thickness of a ramp's slabs [m] (below the driving surface)."""
CONE_SEGMENTS = 16
"""Sides of the polygon approximating a cone's base."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Box:
    """An obstacle: centre ``(x, y, z)`` [m], half sizes ``(sx, sy, sz)`` [m], yaw [rad], colour RGBA 0..1."""

    pos: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    rgba: tuple[float, float, float, float] = (0.9, 0.5, 0.1, 1.0)
    name: str = ""
    """Named in collision reports (default ``box<i>``)."""

    def __post_init__(self) -> None:
        check_numbers(self, "box", ("size",))


@dataclass(frozen=True, slots=True, kw_only=True)
class Cone:
    """A traffic cone standing at ``(x, y)`` [m]: base ``radius`` and ``height`` [m], ``mass`` [kg] (a car
    knocks it over)."""

    pos: tuple[float, float]
    radius: float = 0.18
    height: float = 0.7
    mass: float = 2.0
    rgba: tuple[float, float, float, float] = (1.0, 0.35, 0.0, 1.0)
    name: str = ""
    """Named in collision reports (default ``cone<i>``)."""

    def __post_init__(self) -> None:
        check_numbers(self, "cone", ("radius", "height", "mass"))


@dataclass(frozen=True, slots=True, kw_only=True)
class Ramp:
    """A hump to drive over: from ``start`` ``(x, y)`` [m] in direction ``yaw`` [rad], a slope rising ``height``
    [m] over ``length`` [m], a flat ``top`` [m], and the same slope down; ``width`` [m] across."""

    start: tuple[float, float]
    yaw: float = 0.0
    length: float = 10.0
    height: float = 0.5
    top: float = 5.0
    width: float = 4.0

    def __post_init__(self) -> None:
        check_numbers(self, "ramp", ("length", "height", "width"))
        if self.top < 0:
            raise ValueError(f"ramp top must be >= 0 m, got {self.top!r}")

    @property
    def slope(self) -> float:
        """Angle of the slopes [rad]."""
        return math.atan2(self.height, self.length)


@dataclass(frozen=True, slots=True, kw_only=True)
class Bump:
    """A speed bump centred at ``(x, y)`` [m], across direction ``yaw`` [rad]: ``height`` [m], ``length`` [m]
    along the road, ``width`` [m] across (a circular segment in section)."""

    pos: tuple[float, float]
    yaw: float = 0.0
    height: float = 0.08
    length: float = 0.6
    width: float = 4.0

    def __post_init__(self) -> None:
        check_numbers(self, "bump", ("height", "length", "width"))
        if self.height >= self.length / 2:
            raise ValueError(f"bump height {self.height!r} m must be below half its length {self.length!r} m")

    @property
    def radius(self) -> float:
        """Radius of the circular section whose chord is ``length`` at the ground [m]."""
        return (self.length ** 2 / 4 + self.height ** 2) / (2 * self.height)


@dataclass(frozen=True, slots=True, kw_only=True)
class World:
    """Flat ground (friction coefficient ``ground_friction``) and what stands on it."""

    boxes: tuple[Box, ...] = ()
    cones: tuple[Cone, ...] = ()
    ramps: tuple[Ramp, ...] = ()
    bumps: tuple[Bump, ...] = ()
    ground_friction: float = 1.0

    def __post_init__(self) -> None:
        if not self.ground_friction > 0 or not math.isfinite(self.ground_friction):
            raise ValueError(f"ground_friction must be a finite coefficient > 0, got {self.ground_friction!r}")
        names = self.obstacle_names()
        if len(set(names)) != len(names):
            raise ValueError(f"obstacle names must differ, got {', '.join(names)}")

    @property
    def empty(self) -> bool:
        """Flat ground and nothing on it."""
        return not (self.boxes or self.cones or self.ramps or self.bumps)

    def obstacle_names(self) -> list[str]:
        """Names of the boxes then the cones, as collision reports give them."""
        return [b.name or f"box{i}" for i, b in enumerate(self.boxes)] + \
               [c.name or f"cone{i}" for i, c in enumerate(self.cones)]

    def traffic(self) -> Traffic:
        """The boxes then the cones as obstacles standing still on flat ground, ids 1, 2, ... in that order: a box
        as its footprint, a cone as the polygon of :data:`CONE_SEGMENTS` sides of its base (the 3D plant's mesh)."""
        ring = 2 * np.pi * np.arange(CONE_SEGMENTS) / CONE_SEGMENTS
        outlines = [np.array([(-b.size[0], -b.size[1]), (b.size[0], -b.size[1]), (b.size[0], b.size[1]),
                              (-b.size[0], b.size[1])]) for b in self.boxes]
        outlines += [c.radius * np.column_stack([np.cos(ring), np.sin(ring)]) for c in self.cones]
        outline = np.stack([np.concatenate([o, np.repeat(o[-1:], CONE_SEGMENTS - len(o), axis=0)])
                            for o in outlines])
        poses = [(*b.pos[:2], b.yaw, 0.0) for b in self.boxes] + [(*c.pos, 0.0, 0.0) for c in self.cones]
        m = len(poses)
        return Traffic(ids=np.arange(1, m + 1, dtype=np.int64), static=np.ones(m, bool), outline=outline,
                       states=np.array(poses, float).reshape(m, 1, 4), present=np.ones((m, 1), bool), dt=1.0)


def fmt(*v: float, digits: int = 6) -> str:
    """Numbers as MJCF writes them: space-separated, six significant digits (or ``digits``)."""
    return " ".join(f"{x:.{digits}g}" for x in v)


def _frame(yaw: float, pitch: float = 0.0) -> str:
    """``xyaxes`` of a frame turned by ``yaw`` and then tilted nose up by ``pitch`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    return f'xyaxes="{fmt(c * math.cos(pitch), s * math.cos(pitch), math.sin(pitch), -s, c, 0)}"'


def _ramp(r: Ramp, i: int) -> str:
    """Up slope, flat top and down slope as three slabs whose upper faces are the driving surface."""
    c, s = math.cos(r.yaw), math.sin(r.yaw)
    slope_len = math.hypot(r.length, r.height)
    out = []
    for part, (along, rise, pitch, half) in enumerate((
            (r.length / 2, r.height / 2, r.slope, slope_len / 2),
            (r.length + r.top / 2, r.height, 0.0, r.top / 2),
            (1.5 * r.length + r.top, r.height / 2, -r.slope, slope_len / 2))):
        if half <= 0:
            continue
        # the slab's centre is half its thickness below the surface, along the surface's normal
        along -= -math.sin(pitch) * SLAB / 2
        rise -= math.cos(pitch) * SLAB / 2
        out.append(f'<geom name="ramp{i}_{part}" type="box" class="terrain" size="{fmt(half, r.width / 2, SLAB / 2)}" '
                   f'pos="{fmt(r.start[0] + along * c, r.start[1] + along * s, rise)}" {_frame(r.yaw, pitch)}/>')
    return "".join(out)


def _bump(b: Bump, i: int) -> str:
    c, s = math.cos(b.yaw), math.sin(b.yaw)
    return (f'<geom name="bump{i}" type="cylinder" class="terrain" size="{fmt(b.radius, b.width / 2)}" '
            f'pos="{fmt(b.pos[0], b.pos[1], b.height - b.radius)}" zaxis="{fmt(-s, c, 0)}"/>')


def _cone_mesh(c: Cone, i: int) -> str:
    ring = [(c.radius * math.cos(2 * math.pi * k / CONE_SEGMENTS), c.radius * math.sin(2 * math.pi * k / CONE_SEGMENTS),
             0.0) for k in range(CONE_SEGMENTS)]
    return f'<mesh name="cone{i}" vertex="{fmt(*(v for p in ring for v in p), 0, 0, c.height)}"/>'


def world_xml(world: World) -> tuple[str, str]:
    """MJCF of ``world``: ``(assets, worldbody elements)``; obstacle geoms are named ``obstacle:<name>``."""
    names = world.obstacle_names()
    boxes = "".join(
        f'<geom name="obstacle:{names[i]}" type="box" class="obstacle" pos="{fmt(*b.pos)}" size="{fmt(*b.size)}" '
        f'{_frame(b.yaw)} rgba="{fmt(*b.rgba)}"/>' for i, b in enumerate(world.boxes))
    n = len(world.boxes)
    cones = "".join(f'<body name="cone{i}" pos="{fmt(*c.pos, 0)}"><freejoint/>'
                    f'<geom name="obstacle:{names[n + i]}" type="mesh" mesh="cone{i}" class="obstacle" '
                    f'mass="{c.mass:.6g}" rgba="{fmt(*c.rgba)}"/></body>' for i, c in enumerate(world.cones))
    assets = "".join(_cone_mesh(c, i) for i, c in enumerate(world.cones))
    terrain = "".join(_ramp(r, i) for i, r in enumerate(world.ramps)) + \
        "".join(_bump(b, i) for i, b in enumerate(world.bumps))
    return assets, boxes + cones + terrain
