"""The CPU env's seeded layout draw for many seeds at once, in numba: the same numbers, faster.

A seeded reset of the CPU env draws its arena with :func:`bubblerob_env.arena.sample_layout` from
``gymnasium.utils.seeding.np_random(seed)``: numpy's ``Generator`` over ``PCG64`` seeded through
a ``SeedSequence``. In Python that costs ~0.4 ms a seed (26 s for 65,536 worlds). This module
reproduces the whole chain in numba, bit for bit: ``SeedSequence``'s hash mixing, PCG64's 128-bit
LCG and its XSL-RR output (and the 32-bit half it keeps for the next 32-bit draw), the
``Generator`` draws the layout makes (``random``, ``uniform``, ``integers`` by Lemire's method)
and ``math.hypot`` (CPython's correctly-rounded-in-practice ``vector_norm``, which is not libm's),
so that row ``k`` is exactly the layout the CPU env draws for ``seeds[k]``. tests/warp checks the
layouts against the CPU env's own resets and the generator against numpy's.

Colours (``obstacle_colours``) are drawn after the layout, so they change nothing here; the
MuJoCo Warp backend renders nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["BOX", "CYLINDER", "DrawnLayouts", "draw_layouts", "fill_rows", "hypot", "pcg64_raw"]

CYLINDER, BOX = 0, 1
"""Obstacle kinds in :attr:`DrawnLayouts.kind`."""

_M32 = np.uint64(0xFFFFFFFF)
_SHIFT16 = np.uint64(16)
_SHIFT32 = np.uint64(32)
_ONE = np.uint64(1)
_ZERO = np.uint64(0)
# numpy's SeedSequence (bit_generator.pyx)
_INIT_A = np.uint64(0x43B0D7E5)
_MULT_A = np.uint64(0x931E8875)
_INIT_B = np.uint64(0x8B51F9DD)
_MULT_B = np.uint64(0x58F38DED)
_MIX_MULT_L = np.uint64(0xCA01F9DD)
_MIX_MULT_R = np.uint64(0x4973F715)
# PCG64's 128-bit multiplier (PCG_DEFAULT_MULTIPLIER_128), high and low words
_MUL_HI = np.uint64(2549297995355413924)
_MUL_LO = np.uint64(4865540595714422341)
_DOUBLE_UNIT = 1.0 / 9007199254740992.0  # 2**-53
_SPLITTER = 134217729.0  # 2**27 + 1, Veltkamp's split
# The generator's state: 128-bit state and increment, whether a 32-bit half waits, and the half.
_S_HI, _S_LO, _INC_HI, _INC_LO, _HAS32, _HALF = range(6)


@dataclass(frozen=True)
class DrawnLayouts:
    """The layouts of ``n`` seeds: up to ``width`` obstacles each, in the order they were placed.

    ``kind`` (:data:`CYLINDER` or :data:`BOX`) is ``(n, width)``, ``pose`` (x, y, yaw) ``(n,
    width, 3)``, ``size`` (radius or half x, then half y) ``(n, width, 2)``; ``count`` how many
    of a row's are placed; ``start`` the ``(n, 3)`` start poses (x, y, yaw).
    """

    count: NDArray[np.int64]
    kind: NDArray[np.int64]
    pose: NDArray[np.float64]
    size: NDArray[np.float64]
    start: NDArray[np.float64]


def draw_layouts(
    seeds: NDArray[np.int64],
    arena_size: float,
    num_obstacles: tuple[int, int],
    obstacle_size: tuple[float, float],
    start_clearance: float,
    start_pose: tuple[float, float, float] | None,
    robot_radius: float,
) -> DrawnLayouts:
    """What ``sample_layout(seeding.np_random(seed)[0], ...)`` draws, for every seed in ``seeds``.

    The arguments are :func:`~bubblerob_env.arena.sample_layout`'s. Seeds must be in
    ``[0, 2**63)``.
    """
    seeds = np.asarray(seeds, dtype=np.int64)
    if seeds.size and int(seeds.min()) < 0:
        raise ValueError(f"seeds must be non-negative, got {int(seeds.min())}")
    if arena_size / 2.0 - robot_radius - start_clearance <= 0 and start_pose is None:
        raise ValueError(f"arena_size {arena_size} m is too small for the robot")
    n, width = seeds.size, max(int(num_obstacles[1]), 1)
    out = DrawnLayouts(
        count=np.zeros(n, dtype=np.int64),
        kind=np.zeros((n, width), dtype=np.int64),
        pose=np.zeros((n, width, 3)),
        size=np.zeros((n, width, 2)),
        start=np.zeros((n, 3)),
    )
    fixed = np.zeros(3) if start_pose is None else np.asarray(start_pose, dtype=np.float64)
    settings = np.array(
        [arena_size, start_clearance, robot_radius, *obstacle_size], dtype=np.float64
    )
    _draw_all(
        seeds.astype(np.uint64),
        settings,
        int(num_obstacles[0]),
        int(num_obstacles[1]),
        start_pose is not None,
        fixed,
        out.count,
        out.kind,
        out.pose,
        out.size,
        out.start,
    )
    return out


def pcg64_raw(seed: int, count: int) -> NDArray[np.uint64]:
    """The first ``count`` 64-bit outputs of ``PCG64(SeedSequence(seed))``.

    numpy's ``bit_generator.random_raw(count)``: how tests hold the port to numpy.
    """
    state = np.zeros(6, dtype=np.uint64)
    _seed(state, np.zeros(16, dtype=np.uint64), np.uint64(seed))
    out = np.zeros(count, dtype=np.uint64)
    for i in range(count):
        out[i] = _next64(state)
    return out


@njit(cache=True, nogil=True)
def _hashmix(value: np.uint64, hash_const: np.uint64) -> tuple[np.uint64, np.uint64]:
    value = (value ^ hash_const) & _M32
    hash_const = (hash_const * _MULT_A) & _M32
    value = (value * hash_const) & _M32
    value ^= value >> _SHIFT16
    return value, hash_const


@njit(cache=True, nogil=True)
def _mix(x: np.uint64, y: np.uint64) -> np.uint64:
    result = (_MIX_MULT_L * x - _MIX_MULT_R * y) & _M32
    mixed: np.uint64 = result ^ (result >> _SHIFT16)
    return mixed


@njit(cache=True, nogil=True)
def _mul128(
    a_hi: np.uint64, a_lo: np.uint64, b_hi: np.uint64, b_lo: np.uint64
) -> tuple[np.uint64, np.uint64]:
    """``a * b`` modulo 2**128, in 64-bit words."""
    a0, a1 = a_lo & _M32, a_lo >> _SHIFT32
    b0, b1 = b_lo & _M32, b_lo >> _SHIFT32
    p00, p01, p10, p11 = a0 * b0, a0 * b1, a1 * b0, a1 * b1
    middle = (p00 >> _SHIFT32) + (p01 & _M32) + (p10 & _M32)
    carry_hi = p11 + (p01 >> _SHIFT32) + (p10 >> _SHIFT32) + (middle >> _SHIFT32)
    hi: np.uint64 = carry_hi + a_lo * b_hi + a_hi * b_lo
    lo: np.uint64 = a_lo * b_lo
    return hi, lo


@njit(cache=True, nogil=True)
def _step(state: NDArray[np.uint64]) -> None:
    """PCG64's LCG step: state = state * multiplier + increment (mod 2**128)."""
    hi, lo = _mul128(state[_S_HI], state[_S_LO], _MUL_HI, _MUL_LO)
    new_lo = lo + state[_INC_LO]
    carry = _ONE if new_lo < lo else _ZERO
    state[_S_HI] = hi + state[_INC_HI] + carry
    state[_S_LO] = new_lo


@njit(cache=True, nogil=True)
def _seed(state: NDArray[np.uint64], scratch: NDArray[np.uint64], seed: np.uint64) -> None:
    """Set ``state`` to ``PCG64(SeedSequence(seed))``'s.

    The pool hashed from the seed's 32-bit words, four 64-bit words generated from it, then
    ``pcg64_srandom_r(state=words 0-1, seq=words 2-3)``. ``scratch``: 16 words of room (no
    allocation per seed).
    """
    words, pool, generated = scratch[0:2], scratch[2:6], scratch[6:14]
    words[0], words[1] = seed & _M32, seed >> _SHIFT32
    nwords = 1 if words[1] == _ZERO else 2
    hash_const = _INIT_A
    for i in range(4):
        pool[i], hash_const = _hashmix(words[i] if i < nwords else _ZERO, hash_const)
    for src in range(4):
        for dst in range(4):
            if src != dst:
                hashed, hash_const = _hashmix(pool[src], hash_const)
                pool[dst] = _mix(pool[dst], hashed)
    hash_const = _INIT_B
    for i in range(8):
        value = pool[i % 4] ^ hash_const
        hash_const = (hash_const * _MULT_B) & _M32
        value = (value * hash_const) & _M32
        generated[i] = value ^ (value >> _SHIFT16)
    # Little-endian pairs of 32-bit words: the initial state (0, 1) and the sequence (2, 3).
    val0 = generated[0] | (generated[1] << _SHIFT32)
    val1 = generated[2] | (generated[3] << _SHIFT32)
    val2 = generated[4] | (generated[5] << _SHIFT32)
    val3 = generated[6] | (generated[7] << _SHIFT32)
    state[_S_HI] = state[_S_LO] = state[_HAS32] = state[_HALF] = _ZERO
    state[_INC_HI] = (val2 << _ONE) | (val3 >> np.uint64(63))
    state[_INC_LO] = (val3 << _ONE) | _ONE
    _step(state)
    lo = state[_S_LO] + val1
    carry = _ONE if lo < val1 else _ZERO
    state[_S_HI] = state[_S_HI] + val0 + carry
    state[_S_LO] = lo
    _step(state)


@njit(cache=True, nogil=True)
def _next64(state: NDArray[np.uint64]) -> np.uint64:
    """PCG64's next output: the step, then XSL-RR of the new state."""
    _step(state)
    hi, lo = state[_S_HI], state[_S_LO]
    x = hi ^ lo
    rot = hi >> np.uint64(58)
    rotated: np.uint64 = (x >> rot) | (x << ((np.uint64(64) - rot) & np.uint64(63)))
    return rotated


@njit(cache=True, nogil=True)
def _next32(state: NDArray[np.uint64]) -> np.uint64:
    """Numpy's ``next_uint32``: the low half of a 64-bit output, the high half the next time."""
    if state[_HAS32] != _ZERO:
        state[_HAS32] = _ZERO
        half: np.uint64 = state[_HALF]
        return half
    full = _next64(state)
    state[_HAS32] = _ONE
    state[_HALF] = full >> _SHIFT32
    low: np.uint64 = full & _M32
    return low


@njit(cache=True, nogil=True)
def _random(state: NDArray[np.uint64]) -> float:
    return float(_next64(state) >> np.uint64(11)) * _DOUBLE_UNIT


@njit(cache=True, nogil=True)
def _uniform(state: NDArray[np.uint64], low: float, high: float) -> float:
    return low + (high - low) * _random(state)


@njit(cache=True, nogil=True)
def _integers(state: NDArray[np.uint64], low: int, high: int) -> int:
    """``Generator.integers(low, high + 1)``: Lemire's bounded 32-bit draw (no draw if equal)."""
    span = np.uint64(high - low)
    if span == _ZERO:
        return low
    span_excl = span + _ONE
    m = _next32(state) * span_excl
    leftover = m & _M32
    if leftover < span_excl:
        threshold = (_M32 - span) % span_excl
        while leftover < threshold:
            m = _next32(state) * span_excl
            leftover = m & _M32
    return low + int(m >> _SHIFT32)


@njit(cache=True, nogil=True)
def _two_product(x: float, y: float) -> tuple[float, float]:
    """CPython's ``dl_mul``: Dekker's product with Veltkamp's split (no fma)."""
    t = x * _SPLITTER
    x_hi = t - (t - x)
    x_lo = x - x_hi
    t = y * _SPLITTER
    y_hi = t - (t - y)
    y_lo = y - y_hi
    p = x_hi * y_hi
    q = x_hi * y_lo + x_lo * y_hi
    z = p + q
    return z, p - z + q + x_lo * y_lo


@njit(cache=True, nogil=True)
def hypot(a: float, b: float) -> float:
    """CPython's ``math.hypot(a, b)``, for finite arguments whose larger is a normal number.

    CPython's own algorithm (``vector_norm`` of Modules/mathmodule.c), not libm's ``hypot``:
    the two differ in the last bit now and then, which moves an obstacle.
    """
    a, b = abs(a), abs(b)
    largest = max(a, b)
    if largest == 0.0:
        return 0.0
    _, exponent = math.frexp(largest)
    scale = math.ldexp(1.0, -exponent)
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for value in (a, b):
        x = value * scale
        hi, lo = _two_product(x, x)
        total = csum + hi  # dl_fast_sum(csum, hi)
        frac2 += (csum - total) + hi
        csum = total
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _two_product(-h, h)
    total = csum + hi
    frac2 += (csum - total) + hi
    csum = total
    frac1 += lo
    x = csum - 1.0 + (frac1 + frac2)
    h += x / (2.0 * h)
    return h / scale


@njit(cache=True, nogil=True)
def _draw_all(
    seeds: NDArray[np.uint64],
    settings: NDArray[np.float64],
    low: int,
    high: int,
    fixed_start: bool,
    start_pose: NDArray[np.float64],
    count: NDArray[np.int64],
    kind: NDArray[np.int64],
    pose: NDArray[np.float64],
    sizes: NDArray[np.float64],
    start: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """``sample_layout`` for each seed, draw for draw (see arena.py for the why of each step)."""
    arena_size, start_clearance, radius, size_low, size_high = settings
    half = arena_size / 2.0
    keep_out = radius + start_clearance
    gap = 2 * radius
    pi = math.pi
    state, scratch = np.zeros(6, dtype=np.uint64), np.zeros(16, dtype=np.uint64)
    bounds = np.zeros(kind.shape[1])  # the bounding radius of each obstacle placed
    for k in range(seeds.size):
        _seed(state, scratch, seeds[k])
        if fixed_start:
            sx, sy, syaw = start_pose[0], start_pose[1], start_pose[2]
        else:
            limit = half - keep_out
            sx = _uniform(state, -limit, limit)
            sy = _uniform(state, -limit, limit)
            syaw = _uniform(state, -pi, pi)
        start[k, 0], start[k, 1], start[k, 2] = sx, sy, syaw
        placed = 0
        for _ in range(_integers(state, low, high)):
            is_cylinder = _random(state) < 0.5
            s0 = _uniform(state, size_low, size_high)
            s1 = 0.0 if is_cylinder else _uniform(state, size_low, size_high)
            yaw = 0.0 if is_cylinder else _uniform(state, -pi, pi)
            bound = s0 if is_cylinder else hypot(s0, s1)
            for _ in range(200):  # arena.py's _MAX_TRIES
                limit = half - bound - gap
                if limit <= 0:
                    break
                x = _uniform(state, -limit, limit)
                y = _uniform(state, -limit, limit)
                clear = hypot(x - sx, y - sy) - bound >= keep_out
                for j in range(placed):
                    if not clear:
                        break
                    distance = hypot(x - pose[k, j, 0], y - pose[k, j, 1]) - bound - bounds[j]
                    clear = distance >= gap
                if clear:
                    kind[k, placed] = CYLINDER if is_cylinder else BOX
                    pose[k, placed, 0], pose[k, placed, 1], pose[k, placed, 2] = x, y, yaw
                    sizes[k, placed, 0], sizes[k, placed, 1] = s0, s1
                    bounds[placed] = bound
                    placed += 1
                    break
        count[k] = placed


@njit(cache=True, nogil=True)
def fill_rows(
    drawn_count: NDArray[np.int64],
    drawn_kind: NDArray[np.int64],
    drawn_pose: NDArray[np.float64],
    drawn_size: NDArray[np.float64],
    start: NDArray[np.float64],
    slot_mocaps: NDArray[np.int64],
    half_height: float,
    root_height: float,
    tilt: NDArray[np.float64],
    pos: NDArray[np.float32],
    quat: NDArray[np.float32],
    size: NDArray[np.float32],
    rbound: NDArray[np.float32],
    root: NDArray[np.float32],
) -> None:  # pragma: no cover - numba
    """Write each layout into its table row, as the CPU env writes it into MuJoCo.

    The arithmetic of ``ObstacleSlots.apply`` and ``Scene.place_robot``, in the same order.

    ``pos``, ``quat``, ``size``, ``rbound`` come filled with the reset state (parked slots);
    ``slot_mocaps``: the mocap id of each size column (cylinder slots, then box slots);
    ``drawn_*``: a :class:`DrawnLayouts`' arrays.
    """
    per_kind = slot_mocaps.size // 2
    for k in range(drawn_count.size):
        used = np.zeros(2, dtype=np.int64)
        for j in range(drawn_count[k]):
            kind = drawn_kind[k, j]
            column = kind * per_kind + used[kind]
            used[kind] += 1
            mocap = slot_mocaps[column]
            x, y, yaw = drawn_pose[k, j, 0], drawn_pose[k, j, 1], drawn_pose[k, j, 2]
            pos[k, mocap, 0], pos[k, mocap, 1], pos[k, mocap, 2] = x, y, half_height
            if yaw == 0.0:  # mju_axisAngle2Quat's zero angle: the unit quaternion
                quat[k, mocap, 0], quat[k, mocap, 1] = 1.0, 0.0
                quat[k, mocap, 2], quat[k, mocap, 3] = 0.0, 0.0
            else:
                s = math.sin(yaw * 0.5)
                quat[k, mocap, 0], quat[k, mocap, 1] = math.cos(yaw * 0.5), 0.0 * s
                quat[k, mocap, 2], quat[k, mocap, 3] = 0.0 * s, 1.0 * s
            s0, s1 = drawn_size[k, j, 0], drawn_size[k, j, 1]
            if kind == CYLINDER:
                size[k, column, 0], size[k, column, 1], size[k, column, 2] = s0, half_height, 0.0
                rbound[k, column] = hypot(s0, half_height)
            else:
                size[k, column, 0], size[k, column, 1], size[k, column, 2] = s0, s1, half_height
                rbound[k, column] = math.sqrt(s0 * s0 + s1 * s1 + half_height * half_height)
        c, s = math.cos(start[k, 2] / 2), math.sin(start[k, 2] / 2)
        root[k, 0], root[k, 1], root[k, 2] = start[k, 0], start[k, 1], root_height
        # mju_mulQuat((c, 0, 0, s), tilt), term by term
        t0, t1, t2, t3 = tilt[0], tilt[1], tilt[2], tilt[3]
        root[k, 3] = c * t0 - 0.0 * t1 - 0.0 * t2 - s * t3
        root[k, 4] = c * t1 + 0.0 * t0 + 0.0 * t3 - s * t2
        root[k, 5] = c * t2 - 0.0 * t3 + 0.0 * t0 + s * t1
        root[k, 6] = c * t3 + 0.0 * t2 - 0.0 * t1 + s * t0
