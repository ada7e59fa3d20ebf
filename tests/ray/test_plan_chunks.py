"""How ``--ray`` splits seeds into tasks (no cluster: the plan is plain arithmetic).

Every seed once, in order, in chunks of at most ``MAX_CHUNK`` that shrink to one-episode tasks at
the end, so no CPU waits long for another's last chunk; a given ``chunk_size`` is kept.
"""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from bubblerob_cli.ray.chunks import MAX_CHUNK, plan_chunks


@given(
    first=st.integers(0, 200_000),
    count=st.integers(1, 3000),
    cpus=st.floats(1.0, 64.0),
)
def test_chunks_cover_every_seed_once_and_shrink_to_one(
    first: int, count: int, cpus: float
) -> None:
    chunks = plan_chunks(first, count, cpus)
    assert [seed for chunk in chunks for seed in chunk] == list(range(first, first + count))
    sizes = [len(chunk) for chunk in chunks]
    assert all(1 <= size <= MAX_CHUNK for size in sizes)
    assert sizes == sorted(sizes, reverse=True)
    # Each CPU's last task holds one episode: the others wait one episode for it, at most.
    assert set(sizes[-min(int(cpus), count) :]) == {1}


def test_two_hundred_episodes_on_two_cpus() -> None:
    sizes = [len(chunk) for chunk in plan_chunks(1000, 200, 2)]
    assert sizes[:17] == [10] * 17 and sizes[-4:] == [1, 1, 1, 1] and sum(sizes) == 200


def test_a_given_chunk_size_is_kept() -> None:
    assert plan_chunks(7, 10, 2, chunk_size=4) == [range(7, 11), range(11, 15), range(15, 17)]
