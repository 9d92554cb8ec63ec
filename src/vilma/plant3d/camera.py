"""Cameras on the car: pinhole RGB and depth images of the MuJoCo world, rendered offscreen.

Rendering needs no display and no GPU: MuJoCo draws through EGL (Mesa's llvmpipe on the CPU when there is no
GPU; :mod:`vilma.plant3d` defaults ``MUJOCO_GL`` to ``egl``). MuJoCo is imported by
:meth:`CameraSensor.attach`, so the parameters import without it.

Each sensor owns one EGL context and makes it current only for the length of a render, so it may be attached
on one thread and captured on another (one thread at a time).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from vilma.core.messages import Image, Message
from vilma.plant3d.capture import all_finite, check_mount

if TYPE_CHECKING:
    import mujoco

    from vilma.plant3d.plant import MujocoPlant

MAX_GEOMS = 10_000
"""Capacity of a camera's scene [geoms]."""
MAX_SIDE = 4096
"""Largest image width and height [px]: 16 megapixels, twice a car's 8-megapixel cameras (a frame with depth
is then 200 MB)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class CameraParams:
    """A pinhole camera fixed to the chassis (square pixels, principal point at the image centre)."""

    name: str = "front"
    """Camera and frame name (a word); topics ``camera/<name>`` and ``camera/<name>/depth``."""
    position: tuple[float, float, float] = (1.5, 0.0, 0.6)
    """Optical centre in the body frame from the centre of mass [m]; the default is a windscreen camera of vilma's
    car, 1.39 m above the ground at rest, 0.35 m behind the front of its box body, which it sees as a bonnet in
    the bottom 7 deg of the default view."""
    yaw: float = 0.0
    """Heading of the optical axis from body x, counter-clockwise [rad]."""
    pitch: float = 0.0
    """Tilt of the optical axis below the horizontal plane of the body [rad] (positive looks down)."""
    width: int = 640
    """Image width [px]."""
    height: int = 480
    """Image height [px]."""
    fov_y: float = 60.0
    """Vertical field of view [deg]."""
    rate_hz: float = 10.0
    """Frame rate [Hz]."""
    depth: bool = False
    """Also publish a depth image ``camera/<name>/depth``."""
    near: float = 0.05
    """Near clipping distance along the optical axis [m]: nothing nearer is drawn."""
    far: float = 200.0
    """Far clipping distance along the optical axis [m]: nothing farther is drawn; depth is inf there."""

    def __post_init__(self) -> None:
        what = check_mount("camera", self.name, self.position, self.yaw)
        if not (all_finite(self.pitch) and abs(self.pitch) < math.pi / 2):
            raise ValueError(f"{what} pitch must be between -pi/2 and pi/2 rad (exclusive), got {self.pitch!r}")
        for field in ("width", "height"):
            value = getattr(self, field)
            if not (isinstance(value, int) and not isinstance(value, bool) and 0 < value <= MAX_SIDE):
                raise ValueError(f"{what} {field} must be a whole number of pixels in 1..{MAX_SIDE}, got {value!r}")
        if not (all_finite(self.fov_y) and 0 < self.fov_y < 180):
            raise ValueError(f"{what} fov_y must be between 0 and 180 deg (exclusive), got {self.fov_y!r}")
        if not (all_finite(self.rate_hz) and self.rate_hz > 0):
            raise ValueError(f"{what} rate_hz must be a positive number [Hz], got {self.rate_hz!r}")
        if not isinstance(self.depth, bool):
            raise ValueError(f"{what} depth must be true or false, got {self.depth!r}")
        if not (all_finite(self.near, self.far) and 0 < self.near < self.far):
            raise ValueError(f"{what} near and far must satisfy 0 < near < far [m], got {self.near!r}, {self.far!r}")

    @property
    def focal_px(self) -> float:
        """Focal length [px]: half the height over the tangent of half ``fov_y``."""
        return self.height / 2 / math.tan(math.radians(self.fov_y) / 2)


def stereo_pair(baseline: float = 0.3, **common: object) -> tuple[CameraParams, CameraParams]:
    """Cameras ``front_left`` and ``front_right``, ``baseline`` [m] apart along body y and centred on
    ``position``; ``common``: the other :class:`CameraParams` fields, shared."""
    if not (all_finite(baseline) and baseline > 0):
        raise ValueError(f"stereo baseline must be a positive number [m], got {baseline!r}")
    centre = CameraParams(**common)
    x, y, z = centre.position
    return (replace(centre, name="front_left", position=(x, y + baseline / 2, z)),
            replace(centre, name="front_right", position=(x, y - baseline / 2, z)))


def camera_axes(yaw: float, pitch: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors in the body frame: image right, image up and the optical axis (forward) of a camera at
    ``yaw`` and ``pitch`` [rad]."""
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    forward = np.array([cp * cy, cp * sy, -sp])
    right = np.array([sy, -cy, 0.0])
    return right, np.cross(right, forward), forward


@contextmanager
def _offscreen(model: mujoco.MjModel, width: int, height: int) -> Iterator[None]:
    """Hold the model's offscreen buffer settings at ``width`` x ``height`` [px] and one sample a pixel while a
    render context is made: MuJoCo sizes each context's buffer from them.

    One sample a pixel, at its centre, as a pinhole camera sees it: multisampling (MuJoCo's default 4) costs
    two to three times the render time on the CPU, and the depth it reads back is that of one sample 0.4 pixel
    off the pixel's centre.
    """
    settings, quality = model.vis.global_, model.vis.quality
    saved = settings.offwidth, settings.offheight, quality.offsamples
    settings.offwidth, settings.offheight, quality.offsamples = width, height, 0
    try:
        yield
    finally:
        settings.offwidth, settings.offheight, quality.offsamples = saved


class CameraSensor:
    """A :class:`~vilma.plant3d.capture.WorldSensor` publishing ``rgb8`` images on ``camera/<name>`` and, with
    ``params.depth``, ``32FC1`` depth images (distance along the optical axis [m]) on ``camera/<name>/depth``."""

    def __init__(self, params: CameraParams) -> None:
        self.params = params
        self.name = params.name
        self.rate_hz = params.rate_hz
        self._plant: MujocoPlant | None = None
        self._gl = self._context = None

    def mjcf(self) -> str:
        """A ``<camera>`` named :attr:`name`."""
        p = self.params
        right, up, _ = camera_axes(p.yaw, p.pitch)
        # A MuJoCo camera looks along its -z axis, with its x axis to the image's right and y up in the image:
        # xyaxes gives those two axes in the body frame, and z = x cross y is then minus the optical axis.
        # ipd 0: MuJoCo's two eyes coincide, so the image comes from the optical centre itself.
        return (f'<camera name="{p.name}" pos="{" ".join(f"{v:.9g}" for v in p.position)}" '
                f'xyaxes="{" ".join(f"{v:.9g}" for v in (*right, *up))}" fovy="{p.fov_y:.9g}" ipd="0"/>')

    def attach(self, plant: MujocoPlant) -> None:
        """Make the EGL context, the scene and the image buffers for ``plant`` (again after each rebuild)."""
        import mujoco

        self.close()
        p, m = self.params, plant.model
        if not hasattr(mujoco, "GLContext"):  # MuJoCo found no OpenGL for its MUJOCO_GL backend
            raise RuntimeError(f"camera {self.name!r}: no OpenGL to render with; install EGL and Mesa (Debian: "
                               "apt install libegl1 libegl-mesa0 libgl1-mesa-dri) or remove the cameras")
        self._gl = mujoco.GLContext(p.width, p.height)
        with self._gl.as_current(), _offscreen(m, p.width, p.height):
            try:
                self._context = mujoco.MjrContext(m, mujoco.mjtFontScale.mjFONTSCALE_50)
            except mujoco.FatalError as e:
                raise RuntimeError(f"camera {self.name!r}: no OpenGL context from MuJoCo's "
                                   f"{type(self._gl).__module__} backend; headless rendering needs MUJOCO_GL=egl "
                                   "before MuJoCo's first import (importing vilma.plant3d first sets it)") from e
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self._context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR  # reversed: 1 at near, 0 at far
        self._scene = mujoco.MjvScene(m, maxgeom=MAX_GEOMS)
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._camera.fixedcamid = m.camera(p.name).id
        self._rect = mujoco.MjrRect(0, 0, p.width, p.height)
        self._rgb = np.empty((p.height, p.width, 3), np.uint8)
        self._window_depth = np.empty((p.height, p.width), np.float32) if p.depth else None
        self._metres = np.empty((p.height, p.width), np.dtype("<f4")) if p.depth else None
        self._plant = plant

    def capture(self, stamp_ns: int) -> dict[str, Message]:
        """Render the world from the poses in the plant's data (their kinematics: :meth:`MujocoPlant.step
        <vilma.plant3d.plant.MujocoPlant.step>` brings them to the end of each step)."""
        import mujoco

        if self._plant is None:
            raise RuntimeError(f"camera {self.name!r} captured before attach(plant)")
        p, scene = self.params, self._scene
        mujoco.mjv_updateScene(self._plant.model, self._plant.data, self._option, None, self._camera,
                               mujoco.mjtCatBit.mjCAT_ALL, scene)
        self._clip(scene)
        with self._gl.as_current():
            mujoco.mjr_render(self._rect, scene, self._context)
            mujoco.mjr_readPixels(self._rgb, self._window_depth, self._rect, self._context)
        topic = f"camera/{self.name}"
        out: dict[str, Message] = {topic: Image(stamp_ns=stamp_ns, frame_id=self.name, width=p.width,
                                                height=p.height, encoding="rgb8", step=3 * p.width,
                                                data=self._rgb[::-1].tobytes())}  # OpenGL rows run bottom-up
        if p.depth:
            out[f"{topic}/depth"] = Image(stamp_ns=stamp_ns, frame_id=self.name, width=p.width, height=p.height,
                                          encoding="32FC1", step=4 * p.width, data=self._depth()[::-1].tobytes())
        return out

    def _clip(self, scene: mujoco.MjvScene) -> None:
        """Move the clipping planes MuJoCo derived from the model to ``near`` and ``far``, keeping the field
        of view (the frustum's sides scale with its near distance)."""
        near, far = self.params.near, self.params.far
        for eye in scene.camera:
            k = near / eye.frustum_near
            eye.frustum_bottom, eye.frustum_top, eye.frustum_center = (
                eye.frustum_bottom * k, eye.frustum_top * k, eye.frustum_center * k)
            eye.frustum_near, eye.frustum_far = near, far

    def _depth(self) -> np.ndarray:
        """Distance along the optical axis [m] from the reversed window depth ``w`` (1 at near, 0 at far) of a
        perspective projection: ``near * far / (near + w * (far - near))``; inf where nothing was drawn."""
        n, f = self.params.near, self.params.far
        w, z = self._window_depth, self._metres
        np.multiply(w, f - n, out=z)
        z += n
        np.divide(n * f, z, out=z)
        z[w <= 0] = np.inf
        return z

    def close(self) -> None:
        """Free the EGL context and MuJoCo's render buffers (safe to call twice)."""
        if self._context is not None:
            with self._gl.as_current():
                self._context.free()
        if self._gl is not None:
            self._gl.free()
        self._gl = self._context = None
        self._plant = None
