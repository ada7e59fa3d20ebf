"""Write the notebooks from the cells below and execute them (edit here, then run this).

    python notebooks/make_notebooks.py              # write and execute (outputs committed)
    python notebooks/make_notebooks.py --no-execute # write the cells only

The notebooks are committed with their outputs, so a code host shows them; the tests re-execute
them (nbmake) and check that their cells are the ones below (tests/test_notebooks.py).
"""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).resolve().parent

QUICKSTART = [
    new_markdown_cell(
        "# BubbleRob quickstart\n\n"
        "Make the env, step it, look at its laser, camera and overhead view, compare the built-in "
        "policies, and record a short ROS bag and read it back. Runs on a CPU in about a minute."
    ),
    new_code_cell(
        "import gymnasium as gym\n"
        "import matplotlib.pyplot as plt\n"
        "import numpy as np\n\n"
        "import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)\n\n"
        'env = gym.make("BubbleRob-v0", camera=True, render_mode="rgb_array")\n'
        "action = np.array([0.6, 0.4], np.float32)\n"
        "obs, info = env.reset(seed=0)\n"
        "print(env.observation_space)\n"
        "print(env.action_space)\n"
        "for _ in range(20):\n"
        "    obs, reward, terminated, truncated, info = env.step(action)\n"
        "print(f\"t={info['sim_time']:.2f} s, pose=({info['x']:.2f}, {info['y']:.2f}, \"\n"
        "      f\"{info['yaw']:.2f}), reward={reward:.3f}\")"
    ),
    new_markdown_cell(
        "The laser scan in polar form: ray 0 at `angle_min` (-180 degrees), counter-clockwise, "
        "0 degrees straight ahead (REP 103). No return reads `range_max`."
    ),
    new_code_cell(
        "spec = env.unwrapped.laser_spec\n"
        "fig = plt.figure(figsize=(4, 4))\n"
        'ax = fig.add_subplot(projection="polar")\n'
        'ax.plot(spec.angles(), obs["laser"], ".", markersize=2)\n'
        "ax.set_theta_zero_location('N')  # robot's +x points up\n"
        'ax.set_title("laser scan (m)")\n'
        "plt.show()"
    ),
    new_code_cell(
        "fig, axes = plt.subplots(1, 2, figsize=(8, 4))\n"
        'axes[0].imshow(obs["camera"])\n'
        'axes[0].set_title("camera (64x64)")\n'
        "axes[1].imshow(env.render())\n"
        'axes[1].set_title("overhead, laser drawn")\n'
        "for ax in axes:\n"
        "    ax.axis('off')\n"
        "plt.show()"
    ),
    new_markdown_cell("Compare the built-in policies on a few held-out seeds (100 in README)."),
    new_code_cell(
        "from policies.evaluation import evaluate, format_table\n\n"
        "results = [evaluate(name, episodes=3, env_kwargs={'max_episode_steps': 300})\n"
        '           for name in ("reactive", "laser")]\n'
        "print(format_table(results))"
    ),
    new_markdown_cell(
        "Record a short episode as a ROS 2 MCAP bag and read it back with `rosbags`."
    ),
    new_code_cell(
        "import tempfile\n"
        "from pathlib import Path\n\n"
        "from rosbags.highlevel import AnyReader\n\n"
        "from bubblerob_env.ros import RosBagRecorder\n"
        "from policies import load_policy\n\n"
        "bag = Path(tempfile.mkdtemp()) / 'demo'\n"
        "recorder = RosBagRecorder(gym.make('BubbleRob-v0', max_episode_steps=100), bag)\n"
        "policy = load_policy('laser', recorder)\n"
        "obs, _ = recorder.reset(seed=1)\n"
        "done = False\n"
        "while not done:\n"
        "    obs, reward, terminated, truncated, info = recorder.step(policy.predict(obs)[0])\n"
        "    done = terminated or truncated\n"
        "recorder.close()\n\n"
        "with AnyReader([bag]) as reader:\n"
        "    counts = {c.topic: c.msgcount for c in reader.connections}\n"
        "    scan_connection = [c for c in reader.connections if c.topic == '/scan']\n"
        "    *_, (connection, stamp, raw) = reader.messages(connections=scan_connection)\n"
        "    scan = reader.deserialize(raw, connection.msgtype)\n"
        "print(counts)\n"
        "print('last scan: frame', scan.header.frame_id, 'angle_min', round(scan.angle_min, 3),\n"
        "      'rays', len(scan.ranges))"
    ),
]

TRAINING = [
    new_markdown_cell(
        "# Training a policy\n\n"
        "Train PPO briefly with the repo's configuration (`train/hyperparams/ppo.yml`), plot the "
        "learning curve from the run's evaluation log, and compare with the shipped policy. The "
        "budget here is tiny so the notebook runs in CI; the shipped policy used the command in "
        "`policies/trained/command.txt`."
    ),
    new_code_cell(
        "import tempfile\n"
        "from pathlib import Path\n\n"
        "import matplotlib.pyplot as plt\n"
        "import numpy as np\n\n"
        "from train import train\n\n"
        "out = Path(tempfile.mkdtemp()) / 'ppo'\n"
        "model_path = train('ppo', 'BubbleRob-v0', out, timesteps=4096, eval_freq=1024,\n"
        "                   eval_episodes=2, progress_bar=False,\n"
        "                   overrides={'env_kwargs': {'max_episode_steps': 200}})\n"
        "sorted(p.name for p in out.iterdir())"
    ),
    new_code_cell(
        "log = np.load(out / 'evaluations.npz')\n"
        "fig, ax = plt.subplots(figsize=(5, 3))\n"
        "ax.plot(log['timesteps'], log['results'].mean(axis=1), marker='o')\n"
        "ax.set_xlabel('env steps')\n"
        "ax.set_ylabel('mean evaluation return')\n"
        "ax.set_title('learning curve (tiny budget)')\n"
        "plt.show()"
    ),
    new_code_cell(
        "from policies.evaluation import evaluate, format_table\n\n"
        "kwargs = {'max_episode_steps': 200}\n"
        "print(format_table([evaluate(str(model_path), episodes=2, env_kwargs=kwargs),\n"
        "                    evaluate('ppo', episodes=2, env_kwargs=kwargs)]))"
    ),
]


NOTEBOOKS = {"quickstart": QUICKSTART, "training": TRAINING}
KERNELSPEC = {"name": "python3", "display_name": "Python 3", "language": "python"}


def build(name: str) -> nbformat.NotebookNode:
    """The notebook ``name`` without outputs, with stable cell ids (``name-index``)."""
    notebook = new_notebook(cells=[nbformat.from_dict(cell) for cell in NOTEBOOKS[name]])
    for index, cell in enumerate(notebook.cells):
        cell.id = f"{name}-{index}"
    notebook.metadata["kernelspec"] = dict(KERNELSPEC)
    return notebook


def execute(notebook: nbformat.NotebookNode) -> None:
    """Run every cell in this folder, keeping outputs (no timing metadata)."""
    from nbclient import NotebookClient

    client = NotebookClient(
        notebook,
        timeout=900,
        kernel_name="python3",
        record_timing=False,
        resources={"metadata": {"path": str(HERE)}},
    )
    client.execute()
    notebook.metadata.pop("widgets", None)
    notebook.metadata["kernelspec"] = dict(KERNELSPEC)


def main(argv: list[str] | None = None) -> None:
    """Write (and by default execute) quickstart.ipynb and training.ipynb."""
    import argparse

    parser = argparse.ArgumentParser(description="Write and execute the notebooks.")
    parser.add_argument("--no-execute", action="store_true", help="write the cells only")
    parser.add_argument("names", nargs="*", default=list(NOTEBOOKS), help="notebooks to write")
    args = parser.parse_args(argv)
    for name in args.names:
        notebook = build(name)
        if not args.no_execute:
            execute(notebook)
        nbformat.write(notebook, HERE / f"{name}.ipynb")
        print(f"wrote {HERE / f'{name}.ipynb'}")


if __name__ == "__main__":
    main()
