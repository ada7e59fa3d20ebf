"""Views for ``render()``: an overhead camera with the laser drawn, and a window for humans."""

from __future__ import annotations

import os
import sys
from typing import Any, Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "EnvViews",
    "ForkedAfterRenderingError",
    "HumanViewer",
    "OverheadRenderer",
    "Rays",
    "check_fork_safe",
    "display_available",
    "render_modes_here",
    "scene_option",
]

_HIT_RGBA = np.array([1.0, 0.1, 0.1, 1.0], dtype=np.float32)
_RAY_RGBA = np.array([1.0, 0.6, 0.1, 0.25], dtype=np.float32)
_MAX_DRAWN_RAYS = 90  # more lines than this hide the robot under the fan
_IDENTITY = np.eye(3).reshape(9)


class ForkedAfterRenderingError(RuntimeError):
    """This process was forked from one that had rendered with Mesa: its first frame would hang."""


_forked_after_rendering = False


def _note_fork_in_child() -> None:
    """At a fork, in the child: was a Mesa driver loaded in the parent (it rendered)?"""
    global _forked_after_rendering
    try:
        with open("/proc/self/maps") as maps:  # the child's mappings are the parent's
            _forked_after_rendering = any("/dri/" in line or "libgallium" in line for line in maps)
    except OSError:
        _forked_after_rendering = False


if sys.platform.startswith("linux"):
    os.register_at_fork(after_in_child=_note_fork_in_child)


def check_fork_safe(what: str) -> None:
    """Raise :class:`ForkedAfterRenderingError` instead of making a context that would hang.

    Mesa's software renderer (llvmpipe, our headless EGL) renders with threads made when the
    process first renders; a forked child has none of them, and its first frame waits for them
    forever (``gym.make_vec(..., vectorization_mode="async")`` forks its workers on Linux). A
    parent that set ``LP_NUM_THREADS=0`` before it rendered has no such threads: forking is safe.
    """
    if not _forked_after_rendering or os.environ.get("LP_NUM_THREADS") == "0":
        return
    raise ForkedAfterRenderingError(
        f"{what} cannot render in this process: it was forked from one that had already "
        "rendered with Mesa (llvmpipe), whose threads a fork does not copy, so its first frame "
        "would hang. Start the workers with 'forkserver' or 'spawn' (gym.make_vec(..., "
        "vectorization_mode='async', vector_kwargs={'context': 'forkserver'}); SB3's "
        "SubprocVecEnv does by default), or set LP_NUM_THREADS=0 before the parent renders"
    )


def display_available() -> bool:
    """Whether a window can be opened (always assumed on macOS and Windows)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def render_modes_here(modes: list[str]) -> list[str]:
    """``modes`` without ``"human"`` where no window can be opened: an env's own ``metadata``.

    Gymnasium's ``check_env`` makes the env once in each mode its ``metadata`` lists; headless,
    an env that listed ``"human"`` failed it with default arguments. ``gym.make`` checks the
    class's modes, so ``render_mode="human"`` asked for headless still raises its clear error.
    """
    return [mode for mode in modes if mode != "human" or display_available()]


def scene_option() -> mujoco.MjvOption:
    """Visual options for every view: MuJoCo's rangefinder ray drawing off (cameras saw it)."""
    option = mujoco.MjvOption()
    option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = False
    return option


class OverheadRenderer:
    """Renders the arena from straight above (+x to the right, +y up) with laser rays and hits."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, view_size: float) -> None:
        check_fork_safe("render_mode='rgb_array'")
        max_geom = model.ngeom + 2 * 2048 + 100
        self._renderer = mujoco.Renderer(model, height, width, max_geom=max_geom)
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._camera.lookat[:] = (0.0, 0.0, 0.0)
        self._camera.azimuth = 90.0
        self._camera.elevation = -90.0
        self._camera.distance = 5.0
        # Orthographic: obstacles' tops do not lean away from the centre; the view's height in
        # metres is model.vis.global_.fovy, so scale it to show the whole arena.
        self._camera.orthographic = 1
        self._ortho_extent = 1.05 * view_size
        self._option = scene_option()

    def _update_scene(self, data: mujoco.MjData) -> None:
        saved = self._renderer.model.vis.global_.fovy
        self._renderer.model.vis.global_.fovy = self._ortho_extent
        try:
            self._renderer.update_scene(data, camera=self._camera, scene_option=self._option)
        finally:
            self._renderer.model.vis.global_.fovy = saved

    def render(
        self,
        data: mujoco.MjData,
        laser_origin: NDArray[np.float64] | None = None,
        laser_points: NDArray[np.float64] | None = None,
        laser_hit: NDArray[np.bool_] | None = None,
    ) -> NDArray[np.uint8]:
        """One overhead frame; rays from ``laser_origin`` to ``laser_points``, hits as dots."""
        self._update_scene(data)
        if laser_origin is not None and laser_points is not None and laser_hit is not None:
            scene = self._renderer.scene
            ray_stride = max(1, -(-len(laser_points) // _MAX_DRAWN_RAYS))
            for index, (point, hit) in enumerate(zip(laser_points, laser_hit, strict=True)):
                if scene.ngeom + 2 > scene.maxgeom:
                    break
                if hit:
                    dot = scene.geoms[scene.ngeom]
                    mujoco.mjv_initGeom(
                        dot,
                        mujoco.mjtGeom.mjGEOM_BOX,
                        np.full(3, 0.015),
                        point,
                        _IDENTITY,
                        _HIT_RGBA,
                    )
                    scene.ngeom += 1
                if index % ray_stride:
                    continue
                ray = scene.geoms[scene.ngeom]
                mujoco.mjv_initGeom(
                    ray, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), _IDENTITY, _RAY_RGBA
                )
                mujoco.mjv_connector(ray, mujoco.mjtGeom.mjGEOM_LINE, 1.0, laser_origin, point)
                scene.ngeom += 1
        frame: NDArray[np.uint8] = self._renderer.render()
        return frame

    def close(self) -> None:
        """Free the OpenGL context."""
        self._renderer.close()


class NoDisplayError(RuntimeError, ValueError):
    """``render_mode='human'`` where no window can be opened: a value that cannot work here.

    A ``ValueError`` as every refused kwarg is (one line in the commands); a ``RuntimeError`` as
    it always was.
    """


class HumanViewer:
    """MuJoCo's interactive viewer window, synced once per ``render()`` call."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.require_display()
        import mujoco.viewer  # imported here: it loads GLFW, which needs a display

        self._viewer = mujoco.viewer.launch_passive(model, data)

    @staticmethod
    def require_display() -> None:
        """Raise a clear error where no window can be opened."""
        if not display_available():
            raise NoDisplayError(
                "render_mode='human' opens a window, but no display was found (DISPLAY and "
                "WAYLAND_DISPLAY are unset). Use render_mode='rgb_array' to get frames as arrays, "
                "or run under a display (for example xvfb-run)."
            )

    def render(self) -> None:
        """Show the current state."""
        self._viewer.sync()

    def close(self) -> None:
        """Close the window."""
        self._viewer.close()


class Rays(Protocol):
    """A laser that can tell where its rays end (:class:`~bubblerob_env.sensors.Laser`)."""

    def endpoints(
        self, data: mujoco.MjData, readings: NDArray[np.float32]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The laser's origin and each ray's end at ``readings`` metres."""


class EnvViews:
    """What an env's ``render()`` shows: overhead frames (``rgb_array``) or a window (``human``).

    The renderer or window is made on first use; a copy (pickled, deep-copied) makes its own,
    as OpenGL contexts and windows cannot be copied. A missing display is reported at once.
    """

    def __init__(self, mode: str | None, size: tuple[int, int], view_size: float) -> None:
        self.mode, self.size, self.view_size = mode, size, view_size
        self._overhead: OverheadRenderer | None = None
        self._viewer: HumanViewer | None = None
        if mode == "human":
            HumanViewer.require_display()

    def render(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        laser: Rays | None = None,
        readings: NDArray[np.float32] | None = None,
        range_max: float = 0.0,
    ) -> NDArray[np.uint8] | None:
        """``rgb_array``: a frame, with ``laser``'s rays at ``readings``; ``human``: the window."""
        if self.mode == "human":
            if self._viewer is None:
                self._viewer = HumanViewer(model, data)
            self._viewer.render()
            return None
        if self.mode != "rgb_array":
            return None
        if self._overhead is None:
            self._overhead = OverheadRenderer(model, *self.size, self.view_size)
        if laser is None or readings is None:
            return self._overhead.render(data)
        origin, points = laser.endpoints(data, readings)
        return self._overhead.render(data, origin, points, readings < range_max)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_overhead": None, "_viewer": None}

    def close(self) -> None:
        """Free the renderer and the window."""
        for closable in (self._overhead, self._viewer):
            if closable is not None:
                closable.close()
        self._overhead = self._viewer = None
