"""README's measured figures say where they come from, so that none goes stale unnoticed.

A measured figure is a ratio (``1.6x``, ``2.0-2.8x f1tenth_gym``), a rate (``steps/s``,
``frames/s``), a size (``MB``, ``GB``), a spread (``0.8 ± 0.1``), or a duration or share given as
measured: approximate (``about 90 s``, ``~20 us``), a range (``15-27 s``), signed (``+9.7%``) or
taken (``in 6.5 min``). Settings and definitions (``0.1 s ahead``, ``10% standard deviation``,
``0.455 x 0.381 m``, ``64x64``) are not. Each measured figure's paragraph (for a table, also the
paragraph that introduces it) links a dated section of docs/BENCHMARKS.md, or a docs/results/
file that a bench or test wrote and a test compares with README.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
BENCHMARKS = (ROOT / "docs" / "BENCHMARKS.md").read_text()

_NUM = r"\d[\d,]*(?:\.\d+)?"
_SPAN = rf"{_NUM}(?:\s?(?:-|to)\s?[+~]?{_NUM})?"
_AFTER = r"(?![\w/])"
FIGURE = re.compile(
    "|".join(
        [
            rf"(?<![\w.]){_SPAN}x(?![\w.]|\.\w)",  # ratios: 1.6x, 2.0-2.8x (not 64x64, 4.x)
            rf"(?<![\w.]){_SPAN}\stimes\s(?:faster|slower|as)\b",
            rf"(?<![\w.]){_SPAN}\s?k?\s?(?:robot-)?(?:steps|frames|messages|episodes)/s",
            rf"(?<![\w.]){_SPAN}\s?(?:kB|KB|MB|GB|KiB|MiB|GiB){_AFTER}",
            rf"{_NUM}\s?±\s?{_NUM}",
            # durations and shares: approximate, a range, signed or taken
            rf"(?:(?<!\w)(?:about|around|roughly|nearly|almost|in|took|takes)\s|~\s?){_SPAN}\s?"
            rf"(?:s|ms|us|µs|min|h|%){_AFTER}",
            rf"(?<![\w.]){_NUM}\s?(?:-|to)\s?{_NUM}\s?(?:s|ms|us|µs|min|h|%){_AFTER}",
            rf"(?<![\w])[+]{_NUM}\s?%",
        ]
    )
)
SOURCE = re.compile(r"docs/BENCHMARKS\.md#([\w-]+)|(docs/results/[\w.-]+\.json)")
DATE = re.compile(r"\b20\d\d-\d\d-\d\d\b")


def figures(text: str) -> list[str]:
    """The measured figures in ``text`` (see the module docstring)."""
    return [match.group(0) for match in FIGURE.finditer(text)]


def _paragraphs(markdown: str) -> list[str]:
    """Prose paragraphs and tables, code blocks left out; a table comes with its introduction."""
    prose = re.sub(r"```.*?```", "\n\n", markdown, flags=re.DOTALL)
    blocks = [b.strip() for b in re.split(r"\n\s*\n", prose) if b.strip()]
    return [
        f"{blocks[i - 1]}\n\n{block}" if block.startswith("|") and i > 0 else block
        for i, block in enumerate(blocks)
    ]


def _slug(heading: str) -> str:
    """GitHub's anchor for a Markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _sections(markdown: str) -> dict[str, str]:
    """Each heading's anchor: its text and what follows, up to a heading of its level or above."""
    headings = list(re.finditer(r"^(#+) (.*)$", markdown, flags=re.MULTILINE))
    sections, seen = {}, dict[str, int]()
    for i, heading in enumerate(headings):
        level, slug = len(heading.group(1)), _slug(heading.group(2))
        if slug in seen:  # GitHub numbers repeated headings
            seen[slug] += 1
            slug = f"{slug}-{seen[slug]}"
        else:
            seen[slug] = 0
        end = next(
            (h.start() for h in headings[i + 1 :] if len(h.group(1)) <= level), len(markdown)
        )
        sections[slug] = markdown[heading.start() : end]
    return sections


def test_the_scan_finds_measured_figures_and_leaves_settings_alone() -> None:
    measured = (
        "one env is 1.4-1.6x f1tenth_gym, about 55x real time, 6000-7500 frames/s, "
        "0.8-1.1k robot-steps/s, 19 s and a 291 MB venv, 1.3 GB, about 90 s once, "
        "(15-27 s of start-up), 2 passed in 6.5 min, about 10% of a step, +24% to +33%, "
        "0.89 ± 0.40 m, ~20 us, 126 times faster than real time"
    )
    assert len(figures(measured)) == 15, figures(measured)
    settings = (
        "a 0.455 x 0.381 m body, 64x64 images, vision_msgs 4.x, stamped 0.1 s ahead, a 10% "
        "standard deviation, its Wilson 95% interval, 50 s episodes, 1000 steps, 20 Hz, "
        "within 10 s, 0.5 s after the last command, 300 deg/s, seeds 1000-1049, 3 times a step"
    )
    assert figures(settings) == []


def test_every_measured_figure_in_readme_names_its_source() -> None:
    unsourced = [
        f"{figures(paragraph)} in: {paragraph[:160]!r}"
        for paragraph in _paragraphs(README)
        if figures(paragraph) and not SOURCE.search(paragraph)
    ]
    assert unsourced == [], "\n".join(unsourced)


def test_every_source_readme_names_exists_and_benchmarks_sections_are_dated() -> None:
    sections = _sections(BENCHMARKS)
    anchors = set()
    for anchor, results in SOURCE.findall(README):
        if results:
            assert (ROOT / results).is_file(), results
        else:
            anchors.add(anchor)
    for anchor in sorted(anchors):
        assert anchor in sections, f"docs/BENCHMARKS.md has no heading #{anchor}"
        assert DATE.search(sections[anchor]), f"docs/BENCHMARKS.md#{anchor} gives no date"


def test_learning_curve_caption_is_the_shipped_runs_evaluations() -> None:
    np = pytest.importorskip("numpy")
    run = np.load(ROOT / "policies" / "trained" / "evaluations.npz")
    every = int(np.diff(run["timesteps"])[0])
    assert set(np.diff(run["timesteps"]).tolist()) == {every}
    caption = re.search(r"!\[PPO learning curve: [^\]]* every (\d+)k steps\]", README)
    assert caption is not None and int(caption.group(1)) * 1000 == every
    episodes = re.search(r"\((\d+) validation\s+episodes per evaluation", README)
    assert episodes is not None and int(episodes.group(1)) == run["results"].shape[1]
