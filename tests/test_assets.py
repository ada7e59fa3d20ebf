"""The MJCF assets compile, and every name the code uses exists in every scene."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from bubblerob_env import names
from bubblerob_env.arena import ASSETS_DIR, build_model
from bubblerob_env.robots import ROBOTS, RobotDescription

ROBOT_LIST = list(ROBOTS.values())
# Each scene with the robot it includes: the robots' own, and the test scenes (BubbleRob's).
SCENES = sorted(
    [
        *((robot.scene_file, robot) for robot in ROBOT_LIST),
        *((path, ROBOTS["bubblerob"]) for path in (ASSETS_DIR / "scenes").glob("*.xml")),
    ],
    key=lambda pair: pair[0],
)


def _scene_id(pair: tuple[object, RobotDescription]) -> str:
    return getattr(pair[0], "name", str(pair[0]))


@pytest.mark.parametrize("robot", ROBOT_LIST, ids=lambda r: r.name)
def test_robot_file_compiles_alone_with_its_motors_sensors_and_names(robot):
    model = mujoco.MjModel.from_xml_path(str(robot.robot_file))
    for kind, required in names.REQUIRED_NAMES.items():
        for name in required:
            if name != names.FLOOR_GEOM:  # the floor is the scene's
                assert getattr(model, kind)(name).name == name
    assert model.nu == 2 and model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


@pytest.mark.parametrize("robot", ROBOT_LIST, ids=lambda r: r.name)
def test_robot_radius_bounds_every_robot_geom_seen_from_above(robot):
    # Each geom's horizontal reach from base_link, from the compiled model: sphere and cylinder
    # extents in the plane (cylinders' axes are along y for wheels, z for the laser housing),
    # a box's corners.
    model = mujoco.MjModel.from_xml_path(str(robot.robot_file))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    base = model.body(names.BASE_BODY).id
    reach = 0.0
    for g in range(model.ngeom):
        centre = data.geom_xpos[g] - data.xpos[base]
        size = model.geom_size[g]
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE:
            corners = [centre[:2] + size[0] * np.array(d) for d in ((1, 0), (-1, 0), (0, 1))]
        elif int(model.geom_type[g]) in (
            mujoco.mjtGeom.mjGEOM_BOX,
            mujoco.mjtGeom.mjGEOM_ELLIPSOID,
        ):
            # A box's eight corners seen from above; an ellipsoid's box bounds it.
            axes = data.geom_xmat[g].reshape(3, 3)
            corners = [
                centre[:2] + (axes @ (size * np.array(signs)))[:2]
                for signs in np.ndindex(2, 2, 2)
                for signs in [tuple(2 * np.array(signs) - 1)]
            ]
        else:  # a cylinder: radius size[0] around its axis, half-length size[1] along it
            axis = data.geom_xmat[g].reshape(3, 3)[:, 2][:2]
            side = np.array([-axis[1], axis[0]])
            corners = [
                centre[:2] + a * size[1] * axis + b * size[0] * side
                for a in (-1, 1)
                for b in (-1, 1)
            ]
        reach = max(reach, *(float(np.hypot(*c)) for c in corners))
    # Tight: the radius is the reach rounded up by at most a centimetre.
    assert robot.radius - 0.01 < reach <= robot.radius


@pytest.mark.parametrize(("scene", "robot"), SCENES, ids=[_scene_id(p) for p in SCENES])
def test_scene_compiles_with_every_required_name(scene, robot):
    model = mujoco.MjModel.from_xml_path(str(scene))
    for kind, required in names.REQUIRED_NAMES.items():
        for name in required:
            assert getattr(model, kind)(name).name == name


@pytest.mark.parametrize(("scene", "robot"), SCENES, ids=[_scene_id(p) for p in SCENES])
def test_scene_is_built_from_the_shared_pieces(scene, robot):
    text = scene.read_text()
    for piece in (robot.robot_file.name, "common.xml"):
        assert piece in text, f"{scene.name} does not <include> {piece}"


def test_every_asset_file_is_used_by_a_scene():
    pieces = {"common.xml"} | {robot.robot_file.name for robot in ROBOT_LIST}
    used = pieces | {s.name for s, _ in SCENES}
    on_disk = {p.name for p in ASSETS_DIR.rglob("*.xml")}
    assert on_disk == used


def test_built_model_has_obstacle_slots_and_arena_walls():
    model, has_arena = build_model(ASSETS_DIR / "arena.xml", arena_size=6.0, max_obstacles=3)
    assert has_arena
    for i in range(3):
        model.geom(f"{names.CYLINDER_SLOT_PREFIX}{i}")
        model.geom(f"{names.BOX_SLOT_PREFIX}{i}")
    north = model.geom(names.ARENA_WALLS[0])
    # The wall's inner face is at y = arena_size / 2.
    assert north.pos[1] - north.size[1] == pytest.approx(3.0)


@pytest.mark.parametrize("robot", ROBOT_LIST, ids=lambda r: r.name)
def test_robot_geoms_are_hidden_from_the_laser_and_collide_with_obstacles(robot):
    model = mujoco.MjModel.from_xml_path(str(robot.scene_file))
    base = model.body(names.BASE_BODY).id
    robot = [g for g in range(model.ngeom) if model.body_rootid[model.geom_bodyid[g]] == base]
    assert robot, "the robot has no geoms"
    for g in robot:
        assert model.geom_group[g] == names.ROBOT_GROUP
        if model.geom_conaffinity[g] & 2:
            continue
        # A floor-only geom (the Pioneer's treads) must lie inside one of its body's geoms
        # that hits obstacles: an ellipsoid in a cylinder of the same pose.
        name = model.geom(g).name
        assert (model.geom_contype[g], model.geom_conaffinity[g]) == (1, 1), name
        assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_ELLIPSOID, name
        hull = [
            h
            for h in range(model.ngeom)
            if model.geom_bodyid[h] == model.geom_bodyid[g] and model.geom_conaffinity[h] & 2
        ]
        assert len(hull) == 1, f"{name} has no geom around it that hits obstacles"
        radius, half_width = model.geom_size[hull[0]][:2]
        assert model.geom_size[g][0] == model.geom_size[g][1] <= radius, name
        assert model.geom_size[g][2] <= half_width, name
        assert np.allclose(model.geom_pos[g], model.geom_pos[hull[0]]), name
        assert np.allclose(model.geom_quat[g], model.geom_quat[hull[0]]), name
    walls = [model.geom(n).id for n in names.ARENA_WALLS]
    assert np.all(model.geom_group[walls] == names.OBSTACLE_GROUP)
    assert model.geom(names.FLOOR_GEOM).group == names.FLOOR_GROUP


@pytest.mark.parametrize("robot", ROBOT_LIST, ids=lambda r: r.name)
def test_caster_is_frictionless_with_priority_over_the_floor(robot):
    model = mujoco.MjModel.from_xml_path(str(robot.scene_file))
    caster = model.geom("caster")
    assert caster.condim == 1
    assert caster.priority > model.geom(names.FLOOR_GEOM).priority
    assert caster.friction[0] == 0.0
