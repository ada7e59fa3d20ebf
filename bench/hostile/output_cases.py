"""The campaign's cases of earlier outputs (issue #38, kind 4): never replaced without asking.

Each case writes ``earlier`` files into its fresh folder before the command runs. Without
``--overwrite`` the command must refuse in one line, exit 2, and leave every ``unchanged`` file
as it was; with it, each ``replaced`` file must hold new bytes and each ``absent`` one be gone
(the earlier bag's files), while a user's own files stay (``unchanged``).
"""

from __future__ import annotations

from typing import Any

__all__ = ["output_cases"]

EARLIER = "an earlier output\n"
SHORT = '{"max_episode_steps": 5}'
EVALUATE = ["evaluate", "--policy", "reactive", "--episodes", "1", "--env-kwargs", SHORT]
DEMO = ["demo", "--policy", "reactive", "--episodes", "1", "--env-kwargs", SHORT, "--out", "d"]
RECORD = ["record", "--policy", "reactive", "--max-steps", "3", "--no-progress", "--out", "out"]
TRAIN = [
    "train", "--timesteps", "8", "--n-envs", "1", "--set", "n_steps=8", "--set", "batch_size=8",
    "--eval-freq", "100000", "--no-progress", "--out", "run",
]  # fmt: skip
DEMO_BAG = "d/bubblerob_demo_reactive/earlier.mcap"
RECORD_BAG = "out/bubblerob_reactive_seed0/earlier.mcap"

# (id, argv, the earlier files, what the refusal names)
REFUSED: list[tuple[str, list[str], list[str], str]] = [
    ("map", ["map", "{bag}", "--out", "m.png"], ["m.png"], "m.png"),
    ("localize", ["localize", "{bag}", "--out", "l.png"], ["l.png"], "l.png"),
    ("per-episode", [*EVALUATE, "--per-episode", "e.json"], ["e.json"], "e.json"),
    ("video", [*EVALUATE, "--video", "v.gif"], ["v.gif"], "v.gif"),
    (
        "per-episode-and-video",
        [*EVALUATE, "--per-episode", "e.json", "--video", "v.gif"],
        ["v.gif"],
        "v.gif",
    ),
    ("demo-bag", [*DEMO, "--no-video"], [DEMO_BAG], "bubblerob_demo_reactive"),
    ("demo-video", DEMO, ["d/bubblerob_demo_reactive.mp4"], "bubblerob_demo_reactive.mp4"),
    ("record", RECORD, [RECORD_BAG], "bubblerob_reactive_seed0"),
    (
        "record-per-episode",
        [*RECORD, "--per-episode", "--episodes", "2"],
        ["out/bubblerob_reactive_seed0/episode_000001/earlier.mcap"],
        "episode_000001",
    ),
    (
        "record-ros1",
        [*RECORD, "--format", "ros1"],
        ["out/bubblerob_reactive_seed0.bag"],
        "bubblerob_reactive_seed0.bag",
    ),
    (
        "record-robots",
        [*RECORD, "--robots", "2"],
        ["out/bubblerob_reactive_2robots_seed0/earlier.mcap"],
        "2robots",
    ),
    ("teleop", ["teleop", "--record", "drive"], ["drive/earlier.mcap"], "drive"),
    ("train", TRAIN, ["run/notes.txt"], "run"),
]

# (id, argv with --overwrite, the earlier files, those replaced, those gone, those kept)
REPLACED: list[tuple[str, list[str], list[str], list[str], list[str], list[str]]] = [
    ("map", ["map", "{bag}", "--out", "m.png"], ["m.png"], ["m.png"], [], []),
    ("per-episode", [*EVALUATE, "--per-episode", "e.json"], ["e.json"], ["e.json"], [], []),
    ("demo", [*DEMO, "--no-video"], [DEMO_BAG], [], [DEMO_BAG], []),
    ("record", RECORD, [RECORD_BAG, "out/notes.txt"], [], [RECORD_BAG], ["out/notes.txt"]),
    (
        "train",
        TRAIN,
        ["run/best_model.zip", "run/notes.txt"],
        [],
        ["run/best_model.zip"],
        ["run/notes.txt"],
    ),
]

# Folder outputs named at a file, and --overwrite never making a recording another file.
OTHER: list[tuple[str, list[str], str]] = [
    ("demo-out-file", ["demo", "--policy", "reactive", "--out", "{bag_mcap_file}"], "is a file"),
    ("train-out-file", [*TRAIN[:-1], "{bag_mcap_file}"], "is a file"),
    ("map-at-bag", ["map", "{bag}", "--out", "{bag_mcap_file}", "--overwrite"], ".png"),
    ("per-episode-at-bag", [*EVALUATE, "--per-episode", "{bag_mcap_file}", "--overwrite"], ".json"),
    ("localize-out-at-input", ["localize", "{bag}", "--out", "{bag}", "--overwrite"], "the input"),
]


def output_cases() -> list[dict[str, Any]]:
    """Kind 4: an earlier output refused without ``--overwrite``, replaced with it."""
    cases: list[dict[str, Any]] = []
    for name, argv, earlier, says in REFUSED:
        cases.append(
            {
                "id": f"earlier-{name}",
                "kind": 4,
                "argv": argv,
                "expect": "refuse",
                "exit": 2,
                "stderr_has": ["already exists", "--overwrite", says],
                "earlier": dict.fromkeys(earlier, EARLIER),
                "unchanged": earlier,
            }
        )
    for name, argv, earlier, replaced, absent, kept in REPLACED:
        cases.append(
            {
                "id": f"overwrite-{name}",
                "kind": 4,
                "argv": [*argv, "--overwrite"],
                "expect": "ok",
                "earlier": dict.fromkeys(earlier, EARLIER),
                "replaced": replaced,
                "absent": absent,
                "unchanged": kept,
                "timeout": 240,
            }
        )
    for name, argv, says in OTHER:
        case = {"id": f"output-{name}", "kind": 4, "argv": argv, "expect": "refuse", "exit": 2}
        cases.append({**case, "stderr_has": [says]})
    return cases
