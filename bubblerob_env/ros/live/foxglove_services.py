"""The node's simulation services on a Foxglove server: reset, pause, resume and one step.

ROS users drive CoppeliaSim's helper through topics (``startSimulation``, ``enableSyncMode``,
``triggerNextStep``, ...), which work on Foxglove too; Foxglove's Service Call panel wants
services, as Gazebo offers (``/reset_simulation``, ``/pause_physics``). Each service here is a
``std_srvs/srv/Trigger`` that queues the same control events those topics queue, in order, so
the simulation loop applies them as it applies the topics' (between two steps):

- ``reset_simulation``: a new episode (the next seed), paused again if it was paused;
- ``pause_simulation``: pause;
- ``resume_simulation``: leave sync mode and run;
- ``step_simulation``: enter sync mode and run one control step (then wait for the next call,
  or a ``triggerNextStep``).

The answer says what was queued; the topics (``simulationState``, ``simulationStepDone``) say
when it happened. With several robots (:func:`serve_world`) the same services act on the world.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

from bubblerob_env.ros.live.foxglove import FoxgloveBackend
from bubblerob_env.ros.live.foxglove_robot import publish_marker, publish_robot_model
from bubblerob_env.ros.live.multi_node import MultiSimNode
from bubblerob_env.ros.live.node import PAUSED, NodeConfig, SimNode
from bubblerob_env.ros.messages.robots import robot_frame_prefix, robot_name
from bubblerob_env.ros.messages.topics import namespace_prefix

__all__ = [
    "SERVICE_NAMES",
    "add_simulation_services",
    "node_parameters",
    "serve_simulation",
    "serve_world",
]

SERVICE_NAMES = ("reset_simulation", "pause_simulation", "resume_simulation", "step_simulation")
"""The services, under the node's namespace."""


def add_simulation_services(backend: FoxgloveBackend, node: SimNode, namespace: str = "") -> None:
    """Serve :data:`SERVICE_NAMES` (under ``namespace``) for ``node``'s simulation loop."""
    _add_services(
        backend,
        node.state.push,
        lambda: node.sim_state == PAUSED,
        lambda: node.publisher.episode + 1,
        namespace,
    )


def _add_services(
    backend: FoxgloveBackend,
    push: Callable[[str, bool], None],
    paused: Callable[[], bool],
    next_episode: Callable[[], int],
    namespace: str,
) -> None:
    """The services, queueing control events with ``push`` (a SimNode's or a world's)."""

    def reset() -> tuple[bool, str]:
        was_paused = paused()
        push("stop", True)
        push("start", True)
        if was_paused:
            push("pause", True)
        return True, f"episode {next_episode()} queued" + (", paused" if was_paused else "")

    def pause() -> tuple[bool, str]:
        push("pause", True)
        return True, "pause queued"

    def resume() -> tuple[bool, str]:
        push("enable_sync", False)
        push("start", True)
        return True, "running freely (sync mode off)"

    def step() -> tuple[bool, str]:
        push("enable_sync", True)
        push("start", True)
        push("trigger", True)
        return True, "one step queued (sync mode on)"

    prefix = namespace_prefix(namespace)
    handlers = (reset, pause, resume, step)
    for name, handler in zip(SERVICE_NAMES, handlers, strict=True):
        backend.add_trigger_service(f"{prefix}/{name}", handler)


def serve_simulation(backend: FoxgloveBackend, node: SimNode, namespace: str = "") -> None:
    """Add what a Foxglove server offers beyond ``node``'s topics.

    The services, the robot's body
    (:func:`~bubblerob_env.ros.live.foxglove_robot.publish_robot_model`) and the settings as
    read-only parameters (:func:`node_parameters`).
    """
    add_simulation_services(backend, node, namespace)
    publish_robot_model(backend, node.publisher.env, node.publisher.topics)
    backend.set_parameters(node_parameters(node, namespace))


def serve_world(backend: FoxgloveBackend, node: MultiSimNode) -> None:
    """:func:`serve_simulation` for ``--robots N``: the services act on the world (every robot).

    Each robot's body goes on ``/robot_i/bubblerob/robot_model``, on frame ``robot_i/base_link``.
    """
    _add_services(
        backend,
        node.events.push,
        lambda: node.sim_state == PAUSED,
        lambda: node.world.episodes + 1,
        "",
    )
    radius = float(node.env.config.robot.radius)
    for k in range(node.env.num_robots):
        topic = f"/{robot_name(k)}/bubblerob/robot_model"
        publish_marker(backend, radius, robot_frame_prefix(k), topic)
    values = _settings(node.config, robots=node.env.num_robots)
    backend.set_parameters({f"/bubblerob.{key}": value for key, value in values.items()})


def node_parameters(node: SimNode, namespace: str = "") -> dict[str, bool | int | float | str]:
    """The node's settings as read-only parameters, ``<namespace>/bubblerob.<setting>``."""
    spec = getattr(node.publisher.env, "spec", None)
    prefix = namespace_prefix(namespace)
    values = _settings(node.config, env=getattr(spec, "id", "") or "")
    return {f"{prefix}/bubblerob.{key}": value for key, value in values.items()}


def _settings(config: NodeConfig, **extra: Any) -> dict[str, bool | int | float | str]:
    """``extra`` and ``config``'s settings that a parameter can hold (no ``None``)."""
    values: dict[str, Any] = {**extra, **asdict(config)}
    return {k: v for k, v in values.items() if isinstance(v, (bool, int, float, str))}
