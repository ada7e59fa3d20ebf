"""MCAP chunk CRCs computed in a worker thread beside the compression (issue #40, item 5)."""

from __future__ import annotations

import multiprocessing
import os
import zlib

from bubblerob_env.ros.bags.mcap_crc import BESIDE_FROM, crc_beside


def _in_child(data: bytes) -> int:
    return crc_beside(memoryview(data), len)[0]


def test_the_crc_is_zlibs_and_the_work_runs_on_the_same_bytes() -> None:
    for size in (0, 100, BESIDE_FROM - 1, BESIDE_FROM, 3 * BESIDE_FROM + 7):
        data = os.urandom(size)
        crc, copied = crc_beside(memoryview(data), bytes)
        assert (crc, copied) == (zlib.crc32(data), data)


def test_a_forked_child_gets_its_own_worker() -> None:
    # The parent's worker thread does not survive a fork (recorders in AsyncVectorEnv workers):
    # a child that used the parent's executor would wait for ever.
    data = os.urandom(2 * BESIDE_FROM)
    assert crc_beside(memoryview(data), len)[0] == zlib.crc32(data)  # the parent's worker exists
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.apply_async(_in_child, (data,)).get(timeout=30) == zlib.crc32(data)
