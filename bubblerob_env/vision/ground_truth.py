"""Ground truth for a camera frame: the obstacle or wall each pixel shows, and a labelled box each.

MuJoCo renders the front camera's view once more with segmentation on: each pixel holds the id of
the geom drawn there. A geom is an obstacle when its world position is one of the layout's
obstacles (so the layout, not the slot bookkeeping, says which obstacle it is) or a wall when it is
one of the arena's walls. Bearing and distance come from the layout's geometry and the camera's
pose (:mod:`~bubblerob_env.vision.geometry`), not from the pixels: an independent check of what a
recogniser estimates from the image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.arena import ArenaLayout
from bubblerob_env.sensors import CameraSpec
from bubblerob_env.vision.geometry import CameraPose, wall_point

__all__ = ["GroundTruthCamera", "LabelledObject", "label_segmentation"]

_MATCH_TOLERANCE = 1e-6  # metres between a slot geom's position and its obstacle's


@dataclass(frozen=True)
class LabelledObject:
    """One object visible in a frame.

    ``object_id`` is ``"obstacle_<i>"`` (``i``: its index in ``layout.obstacles``) or the wall's
    geom name (``"wall_north"``, ...). ``box`` is ``(u_min, v_min, u_max, v_max)``, inclusive
    pixel indices (u: column, v: row from the top). ``bearing`` (radians, positive left of the
    optical axis) and ``distance`` (m, horizontal) are to an obstacle's axis or to a wall's
    nearest point.
    """

    kind: str
    object_id: str
    colour: str | None
    box: tuple[int, int, int, int]
    pixels: int
    bearing: float
    distance: float
    geom_id: int = -1
    """The MuJoCo geom the pixels show (the segmentation's value)."""

    @property
    def bearing_deg(self) -> float:
        """``bearing`` in degrees."""
        return math.degrees(self.bearing)


class GroundTruthCamera:
    """Renders the front camera's segmentation: ``(height, width)`` geom ids, -1 where none.

    The OpenGL context is made on the first frame (as :class:`~bubblerob_env.sensors.CameraSensor`
    does), so the object can be built before a fork.
    """

    def __init__(self, model: mujoco.MjModel, spec: CameraSpec) -> None:
        self.spec = spec
        self._model = model
        self._renderer: mujoco.Renderer | None = None
        self._camera = model.camera(names.FRONT_CAMERA).id
        self._option = mujoco.MjvOption()
        self._option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = False

    def segment(self, data: mujoco.MjData) -> NDArray[np.int32]:
        """The geom id each pixel shows (-1: nothing, or something that is not a geom)."""
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self._model, self.spec.height, self.spec.width)
            self._renderer.enable_segmentation_rendering()
        self._renderer.update_scene(data, camera=self._camera, scene_option=self._option)
        ids_types: NDArray[np.int32] = self._renderer.render()
        is_geom = ids_types[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
        return np.where(is_geom, ids_types[..., 0], -1).astype(np.int32)

    def label(self, env: Any, min_pixels: int = 1) -> list[LabelledObject]:
        """The labelled objects of the frame ``env`` (a ``BubbleRobEnv``, unwrapped) shows now."""
        segmentation = self.segment(env.data)
        return label_segmentation(segmentation, env.model, env.data, env.layout, min_pixels)

    def close(self) -> None:
        """Free the OpenGL context, if one was made."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _object_geoms(
    model: mujoco.MjModel, data: mujoco.MjData, layout: ArenaLayout
) -> dict[int, tuple[str, str, str | None, tuple[float, float] | None]]:
    """Map geom id -> (kind, object id, colour, centre or None for walls)."""
    geoms: dict[int, tuple[str, str, str | None, tuple[float, float] | None]] = {}
    for name in names.ARENA_WALLS:
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if geom >= 0:
            geoms[geom] = ("wall", name, None, None)
    prefixes = {"cylinder": names.CYLINDER_SLOT_PREFIX, "box": names.BOX_SLOT_PREFIX}
    slot_geoms = {
        kind: [g for g in range(model.ngeom) if (model.geom(g).name or "").startswith(prefix)]
        for kind, prefix in prefixes.items()
    }
    for index, obstacle in enumerate(layout.obstacles):
        found = [
            g
            for g in slot_geoms[obstacle.kind]
            if abs(data.geom_xpos[g][0] - obstacle.x) < _MATCH_TOLERANCE
            and abs(data.geom_xpos[g][1] - obstacle.y) < _MATCH_TOLERANCE
        ]
        if len(found) != 1:
            raise RuntimeError(f"obstacle {index} ({obstacle}) matches {len(found)} slot geoms")
        geoms[found[0]] = (
            obstacle.kind,
            f"obstacle_{index}",
            obstacle.colour,
            (obstacle.x, obstacle.y),
        )
    return geoms


def label_segmentation(
    segmentation: NDArray[np.int32],
    model: mujoco.MjModel,
    data: mujoco.MjData,
    layout: ArenaLayout,
    min_pixels: int = 1,
) -> list[LabelledObject]:
    """One :class:`LabelledObject` per obstacle or wall with at least ``min_pixels`` pixels.

    Ordered by pixel count, largest first.
    """
    pose = CameraPose.of(model, data)
    geoms = _object_geoms(model, data, layout)
    ids, counts = np.unique(segmentation, return_counts=True)
    objects = []
    for geom, count in zip(ids.tolist(), counts.tolist(), strict=True):
        if geom not in geoms or count < min_pixels:
            continue
        kind, object_id, colour, centre = geoms[geom]
        rows, cols = np.nonzero(segmentation == geom)
        point = centre if centre is not None else wall_point(model, data, geom, pose)
        objects.append(
            LabelledObject(
                kind=kind,
                object_id=object_id,
                colour=colour,
                box=(int(cols.min()), int(rows.min()), int(cols.max()), int(rows.max())),
                pixels=int(count),
                bearing=pose.bearing(*point),
                distance=pose.distance(*point),
                geom_id=geom,
            )
        )
    objects.sort(key=lambda o: -o.pixels)
    return objects
