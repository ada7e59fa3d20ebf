"""Episodes as a stream of frames in simulated time: what the recorder and live publisher share.

:class:`EpisodeStream` stamps an episode's frames ``start + info["sim_time"]``, starts each
episode one control step after the previous one ended (so that stamps increase strictly across
episodes), numbers the frames, and sends them with the episode's metadata record (and
``/tf_static`` first) to a :class:`~bubblerob_env.ros.serialize.MessageFanout`. The
:class:`~bubblerob_env.ros.recorder.RosBagRecorder` and the
:class:`~bubblerob_env.ros.live.wrapper.RosLivePublisher` both write through one, so that a live
run and a recording of the same seeds and actions carry the same stamps.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, SupportsFloat

from numpy.typing import NDArray

from bubblerob_env.ros.serialize import MessageFanout

__all__ = ["EpisodeStream"]


class EpisodeStream:
    """Frames of consecutive episodes into ``fanout``, stamped in simulated nanoseconds.

    Args:
        fanout: Where the frames and records go.
        dt_ns: Simulated nanoseconds per env step (the gap before an episode's first frame).
    """

    def __init__(self, fanout: MessageFanout, dt_ns: int) -> None:
        self.fanout = fanout
        self.dt_ns = dt_ns
        self.seq = 0
        """Sequence number of the next frame (never restarts)."""
        self.last_ns: int | None = None
        """Stamp of the latest frame; ``None`` before the first (or after :meth:`restart`)."""
        self._offset_ns = 0

    def restart(self) -> None:
        """Start again at time 0 with ``/tf_static`` (a new bag); sequence numbers go on."""
        self.last_ns = None

    def next_start(self) -> int:
        """The stamp the next episode's first frame will get."""
        return 0 if self.last_ns is None else self.last_ns + self.dt_ns

    def begin(
        self, obs: Mapping[str, NDArray[Any]], info: Mapping[str, Any], metadata: Mapping[str, Any]
    ) -> int:
        """Send a new episode's metadata record and first frame (after a reset); its start stamp.

        ``/tf_static`` goes first when the stream (re)starts.
        """
        start = self.next_start()
        self._offset_ns = start - round(float(info["sim_time"]) * 1e9)
        if self.last_ns is None:
            self.fanout.write_records(lambda s: s.tf_static(start))
        self.fanout.write_records(lambda s: [s.episode(metadata, start)])
        self.fanout.write_frame(obs, info, start, self.seq)
        self.seq += 1
        self.last_ns = start
        return start

    def step(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        action: Any,
        reward: SupportsFloat,
        terminated: bool,
        truncated: bool,
    ) -> int:
        """Send the frame after a step; the action's topics are stamped with the frame before it.

        Returns the frame's stamp.
        """
        stamp = self._offset_ns + round(float(info["sim_time"]) * 1e9)
        self.fanout.write_frame(  # positional: called every step
            obs, info, stamp, self.seq, action, self.last_ns, reward, terminated, truncated
        )
        self.seq += 1
        self.last_ns = stamp
        return stamp
