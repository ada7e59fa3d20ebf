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
when it happened.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from bubblerob_env.ros.live.foxglove import FoxgloveBackend
from bubblerob_env.ros.live.foxglove_robot import publish_robot_model
from bubblerob_env.ros.live.node import PAUSED, SimNode
from bubblerob_env.ros.messages.topics import namespace_prefix

__all__ = ["SERVICE_NAMES", "add_simulation_services", "node_parameters", "serve_simulation"]

SERVICE_NAMES = ("reset_simulation", "pause_simulation", "resume_simulation", "step_simulation")
"""The services, under the node's namespace."""


def add_simulation_services(backend: FoxgloveBackend, node: SimNode, namespace: str = "") -> None:
    """Serve :data:`SERVICE_NAMES` (under ``namespace``) for ``node``'s simulation loop."""
    push = node.state.push

    def reset() -> tuple[bool, str]:
        paused = node.sim_state == PAUSED
        push("stop", True)
        push("start", True)
        if paused:
            push("pause", True)
        return True, f"episode {node.publisher.episode + 1} queued" + (", paused" if paused else "")

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


def node_parameters(node: SimNode, namespace: str = "") -> dict[str, bool | int | float | str]:
    """The node's settings as read-only parameters, ``<namespace>/bubblerob.<setting>``."""
    spec = getattr(node.publisher.env, "spec", None)
    values: dict[str, Any] = {"env": getattr(spec, "id", "") or "", **asdict(node.config)}
    prefix = namespace_prefix(namespace)
    return {
        f"{prefix}/bubblerob.{key}": value
        for key, value in values.items()
        if isinstance(value, (bool, int, float, str))
    }
