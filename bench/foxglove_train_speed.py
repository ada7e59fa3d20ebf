"""Training steps/s with and without ``train --foxglove`` (issue #39: at most 5% slower).

Usage: ``python bench/foxglove_train_speed.py [--pairs N] [--timesteps T] [--client] [--budget B]``

Each pair trains PPO on BubbleRob-v0 twice in this process with the project's hyperparameters
(8 envs, ``--vec-env dummy``, ``--torch-threads 1``, no evaluation inside the timed part): once
plain and once with the first env published live to Foxglove (``train --foxglove``; a port the
OS chose), in alternating order (A B, B A, A B, ...) so that both see the same load. Each run's
rate is its own: the timesteps over ``model.learn``'s wall time (``train_time.json``). Prints
every pair's slowdown (plain steps/s over Foxglove steps/s), their median and spread, and the
machine's load.

``--client``: a viewer is connected while the Foxglove runs train. A separate process (as
Foxglove itself would be) speaks Foxglove's WebSocket protocol (``websockets``, subprotocol
``foxglove.sdk.v1``), subscribes to every channel the server advertises and reads every message.
Without it nobody is connected (what ``train --foxglove`` costs when nobody watches). Neither
needs Node. ``--budget``: the publisher's budget instead of ``train.envs.WATCH_BUDGET`` (to try
another).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TARGET = 1.05
TALLY = Path(tempfile.gettempdir()) / f"bubblerob-fox-bench-{os.getpid()}.count"
_CLIENT = r"""
import asyncio, json, sys, websockets

received = 0

async def watch(url):
    global received
    async with websockets.connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None) as ws:
        subscribed = set()
        async for message in ws:
            if not isinstance(message, str):  # a message of a subscribed channel
                received += 1
                if received % 100 == 1:
                    with open(sys.argv[2], "w") as tally:
                        tally.write(str(received))
            if isinstance(message, str):
                op = json.loads(message)
                if op.get("op") == "advertise":
                    new = [c["id"] for c in op["channels"] if c["id"] not in subscribed]
                    subscribed.update(new)
                    subs = [{"id": i, "channelId": i} for i in new]
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

async def main(url):
    while True:  # each Foxglove run starts a server: connect to every one
        try:
            await watch(url)
        except (OSError, websockets.exceptions.WebSocketException):
            await asyncio.sleep(0.05)

asyncio.run(main(sys.argv[1]))
"""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _train_rate(foxglove: tuple[str, int] | None, timesteps: int, seed: int) -> float:
    """Steps/s of one PPO run (``model.learn``'s own wall time)."""
    from train.trainer import train

    with tempfile.TemporaryDirectory(prefix="bubblerob-fox-bench-") as folder:
        out = Path(folder)
        train(
            "ppo",
            "BubbleRob-v0",
            out,
            timesteps=timesteps,
            seed=seed,
            eval_freq=10 * timesteps,  # no evaluation during the run
            eval_episodes=1,
            progress_bar=False,
            vec_env="dummy",
            torch_threads=1,
            foxglove=foxglove,
        )
        record = json.loads((out / "train_time.json").read_text())
    return float(record["timesteps"]) / float(record["wall_time_s"])


def measure(
    pairs: int, timesteps: int, client: bool, warm_up: bool = True
) -> list[tuple[float, float]]:
    """(plain, Foxglove) steps/s of each pair, the order alternating from pair to pair."""
    port = _free_port()
    viewer = None
    if client:
        url = f"ws://127.0.0.1:{port}"
        viewer = subprocess.Popen([sys.executable, "-c", _CLIENT, url, str(TALLY)])
    try:
        if warm_up:  # imports, numba's cache, torch's first calls
            _train_rate(None, 4096, 0)
        results = []
        for pair in range(pairs):
            rates: dict[bool, float] = {}
            for watched in (False, True) if pair % 2 == 0 else (True, False):
                address = ("127.0.0.1", port) if watched else None
                rates[watched] = _train_rate(address, timesteps, seed=pair)
            results.append((rates[False], rates[True]))
            slowdown = rates[False] / rates[True]
            print(
                f"pair {pair + 1}: plain {rates[False]:.0f} steps/s, foxglove {rates[True]:.0f} "
                f"steps/s, slowdown {slowdown:.3f}",
                flush=True,
            )
        return results
    finally:
        if viewer is not None:
            viewer.terminate()
            viewer.wait()
            # A slowdown with a viewer means something only if the viewer got the episodes.
            got = int(TALLY.read_text()) if TALLY.exists() else 0
            TALLY.unlink(missing_ok=True)
            print(f"the client received at least {got} messages over the Foxglove runs")
            if got == 0:
                raise SystemExit("FAIL: the client received nothing: no slowdown was measured")


def report(results: list[tuple[float, float]], client: bool) -> list[str]:
    """The median slowdown, its spread, the verdict and the machine."""
    slowdowns = sorted(plain / watched for plain, watched in results)
    median = statistics.median(slowdowns)
    verdict = "PASS" if median <= TARGET else "FAIL"
    from train.envs import WATCH_BUDGET

    viewer = "a subscribed client connected" if client else "no client connected"
    viewer += f", budget {WATCH_BUDGET}"
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return [
        f"{verdict}: train --foxglove ({viewer}) slows training by a median factor of "
        f"{median:.3f} over {len(slowdowns)} pairs (spread {slowdowns[0]:.3f}-"
        f"{slowdowns[-1]:.3f}; target <= {TARGET})",
        f"plain {statistics.median(p for p, _ in results):.0f} steps/s, foxglove "
        f"{statistics.median(w for _, w in results):.0f} steps/s (medians)",
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load "
        f"average {load} (1/5/15 min, at the end); date {now}",
    ]


def main(argv: list[str] | None = None) -> int:
    """Measure and print; the exit status is 0 whatever the target says."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--pairs", type=int, default=6, help="plain/Foxglove pairs (6)")
    parser.add_argument(
        "--timesteps", type=int, default=16384, help="timesteps of each run (16384)"
    )
    parser.add_argument("--client", action="store_true", help="a viewer subscribes to everything")
    parser.add_argument("--budget", type=float, help="the publisher's budget (WATCH_BUDGET)")
    parser.add_argument("--quick", action="store_true", help="smoke test: 1 pair of 4096 steps")
    args = parser.parse_args(argv)
    if args.quick:
        args.pairs, args.timesteps = 1, 4096
    if args.pairs < 1 or args.timesteps < 1:
        parser.error("--pairs and --timesteps must be >= 1")
    sys.path.insert(0, str(HERE.parent))  # train/ is not an installed package
    from bubblerob_cli.foxglove_view import quiet_sdk_log

    quiet_sdk_log("bench")
    if args.budget is not None:
        import train.envs

        train.envs.WATCH_BUDGET = args.budget  # WatchFirst reads it when it makes the env
    start = time.perf_counter()
    results = measure(args.pairs, args.timesteps, args.client, warm_up=not args.quick)
    print("\n".join(report(results, args.client)))
    print(f"({time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
