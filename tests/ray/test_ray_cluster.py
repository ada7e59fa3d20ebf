"""Two Ray nodes on one machine (ray.cluster_utils.Cluster): tasks on both, results as serial."""

from __future__ import annotations

from pathlib import Path

from ray_helpers import as_json, need_netns, run_scenarios

from bubblerob_env.ros.readback.replay import replay_bag
from policies.evaluation import evaluate

SHORT = {"max_episode_steps": 120}


def test_two_nodes_evaluate_and_record_as_one(tmp_path: Path) -> None:
    need_netns()
    record = [
        "--policy",
        "reactive",
        "--episodes",
        "4",
        "--max-steps",
        "80",
        "--out",
        str(tmp_path),
    ]
    wanted = {"multi_node": {"episodes": 6, "seed": 1000, "env_kwargs": SHORT, "record": record}}
    result = run_scenarios(wanted, tmp_path)["multi_node"]
    evaluated = result["evaluate"]
    assert len(evaluated["nodes"]) == 2, "every task ran on one node"
    assert [e["seed"] for e in evaluated["episodes"]] == list(range(1000, 1006))
    assert evaluated["rows"] == [as_json(evaluate("reactive", 6, 1000, env_kwargs=SHORT))]
    assert result["record"]["code"] == 0, result["record"]["stderr"]
    assert "on 2 node(s)" in result["record"]["stdout"]
    bags = sorted(p for p in tmp_path.iterdir() if p.name.startswith("bubblerob_"))
    assert [b.name for b in bags] == [f"bubblerob_reactive_seed{s}-{s}" for s in range(4)]
    for bag in bags:
        assert replay_bag(bag).ok
