"""``--foxglove [[HOST:]PORT]`` of ``evaluate`` and ``demo``: watch the episodes live in Foxglove.

The episodes go out as ``bubblerob node --foxglove`` serves them (the same topics, types and
stamps; :mod:`~bubblerob_env.ros.live.foxglove`), one server for the whole run. Each policy's
episodes follow the previous one's in simulated time, so Foxglove's clock never goes back.
"""

from __future__ import annotations

import argparse
import logging
import sys
from typing import TYPE_CHECKING, Any

from bubblerob_cli.errors import fail
from bubblerob_env.extras import require_extra

if TYPE_CHECKING:
    from bubblerob_env.ros.live.foxglove import FoxgloveBackend
    from policies.evaluation import EvalResult

__all__ = [
    "DEFAULT_ADDRESS",
    "add_foxglove_option",
    "evaluate_live",
    "parse_address",
    "quiet_sdk_log",
    "serve",
]

DEFAULT_ADDRESS = "127.0.0.1:8765"


def parse_address(text: str) -> tuple[str, int]:
    """``PORT`` or ``HOST:PORT`` (port 0: any free one) -> ``(host, port)``."""
    host, sep, port = text.rpartition(":")
    host = host if sep else "127.0.0.1"
    if not port.isdigit() or not 0 <= int(port) <= 65535 or (sep and not host):
        raise argparse.ArgumentTypeError(
            f"expected PORT or HOST:PORT with a port from 0 (any free one) to 65535, got {text!r}"
        )
    return host, int(port)


def add_foxglove_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--foxglove [[HOST:]PORT]``."""
    parser.add_argument(
        "--foxglove",
        nargs="?",
        const=parse_address(DEFAULT_ADDRESS),
        type=parse_address,
        metavar="[HOST:]PORT",
        help=f"publish the episodes live to Foxglove on a WebSocket server ({DEFAULT_ADDRESS} "
        "without a value; port 0: any free one; the [foxglove] extra)",
    )


class _OncePerKind(logging.Handler):
    """Writes the first record of each kind (logger and level) as one line; drops the rest."""

    def __init__(self, command: str) -> None:
        super().__init__(logging.WARNING)
        self.command = command
        self.seen: set[tuple[str, int]] = set()

    def emit(self, record: logging.LogRecord) -> None:
        kind = (record.name, record.levelno)
        if kind in self.seen:
            return
        self.seen.add(kind)
        print(
            f"bubblerob {self.command}: foxglove-sdk: {record.getMessage()} (further ones of this "
            "kind are not logged)",
            file=sys.stderr,
            flush=True,
        )


def quiet_sdk_log(command: str) -> None:
    """Write foxglove-sdk's own warnings as one line per kind on stderr, not one per client.

    They are about clients: one gone mid-message, a failed handshake (a wrong subprotocol).
    """
    sdk = logging.getLogger("foxglove")
    if not any(isinstance(handler, _OncePerKind) for handler in sdk.handlers):
        sdk.addHandler(_OncePerKind(command))
        sdk.propagate = False


def serve(command: str, address: tuple[str, int]) -> FoxgloveBackend:
    """A started Foxglove server, announced in one line; one line and exit 2 if it cannot start."""
    require_extra("foxglove", f"bubblerob {command} --foxglove")
    from bubblerob_env.ros.live.backend import BackendError
    from bubblerob_env.ros.live.foxglove import SUBPROTOCOL, FoxgloveBackend

    quiet_sdk_log(command)
    try:
        backend = FoxgloveBackend(*address)
    except BackendError as error:
        fail(command, str(error))
    print(f"bubblerob {command}: Foxglove at {backend.url} (subprotocol {SUBPROTOCOL})", flush=True)
    return backend


def evaluate_live(args: argparse.Namespace) -> list[EvalResult]:
    """``evaluate``'s episodes, each policy in turn, published to Foxglove as they run."""
    import gymnasium as gym
    from tqdm import tqdm

    from bubblerob_env.ros.live.foxglove_robot import publish_robot_model
    from bubblerob_env.ros.live.wrapper import RosLivePublisher
    from policies.evaluation import run_episode, summarize
    from policies.loading import load_policy

    backend = serve("evaluate", args.foxglove)
    results, start = [], None
    try:
        for name in args.policy:
            env = RosLivePublisher(
                gym.make(args.env, **args.env_kwargs),
                backend,
                start_time=start,
                metadata={"policy": str(name)},
            )
            publish_robot_model(backend, env, env.topics)
            policy = load_policy(name, env)
            seeds = range(args.seed, args.seed + args.episodes)
            bar: Any = tqdm(seeds, desc=f"evaluate {name}", unit="episode")
            results.append(summarize(str(name), [run_episode(env, policy, s) for s in bar]))
            if env.stamp_ns is not None:
                start = _seconds(env.stamp_ns + env.dt_ns)
            env.close()
    finally:
        backend.shutdown("done")
    return results


def _seconds(stamp_ns: int) -> str:
    """A stamp as ``start_time`` takes it, to the nanosecond (a float would round it)."""
    return f"{stamp_ns // 10**9}.{stamp_ns % 10**9:09d}"
