"""Frames in, serialised records out to every sink; each message serialised once per distro.

:class:`MessageFanout` turns a frame into field values once, packs it once per distro and framing
among its sinks (:class:`~bubblerob_env.ros.fastpath.serializer.FrameSerializer`), and gives the
same bytes to each sink: a recorder has one sink; live publishing adds more. When every sink
frames records (a recorder), frames after steps are gathered and packed in batches instead
(:mod:`~bubblerob_env.ros.fastpath.batch`): the same bytes at a fraction of the cost per step.
Bags and live publishers alike meet the :class:`~bubblerob_env.ros.sink.Sink` protocol: the
fan-out imports neither ``bags`` nor ``live``, which both build on it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol, SupportsFloat

from numpy.typing import NDArray

from bubblerob_env.ros.fastpath.batch import FrameBatch
from bubblerob_env.ros.fastpath.framing import FrameLayout, Framing, PackedWriter, Record
from bubblerob_env.ros.fastpath.serializer import FramePacker, FrameSerializer
from bubblerob_env.ros.messages.detections import Recognised
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.sink import Sink
from bubblerob_env.specs import EnvSpecs

__all__ = ["Detector", "MessageFanout"]

_Send = Callable[[tuple[Any, ...], int, int], None]  # (frame args, stamp, action stamp)


class Detector(Protocol):
    """What the fan-out needs of a recogniser: a ``bubblerob_env.vision`` ``Recogniser``."""

    def __call__(self, image: NDArray[Any], /) -> Sequence[Recognised]:
        """The objects in one ``(height, width, 3)`` image."""

    def many(self, images: NDArray[Any], /) -> Sequence[Sequence[Recognised]]:
        """The objects in each of ``(n, height, width, 3)`` images, as ``n`` calls would find."""


class _BatchWriters:
    """The sinks of one distro and framing that take a batch's packed frames.

    Without ``/detections``: each sink's :meth:`~bubblerob_env.ros.sink.Sink.packed_batch_writer`
    takes the whole batch. With them (``detects``), each frame's detections record follows it,
    so each sink gets what it gets frame by frame: the frame
    (:meth:`~bubblerob_env.ros.sink.Sink.packed_writer`), then its record: the same calls, so
    the same bytes, with the frames converted, packed and recognised in one go.
    """

    def __init__(self, sinks: list[Sink], detects: bool) -> None:
        gathered = [getattr(sink, "write_gathered", None) for sink in sinks]
        self.gathered_writers: list[Any] = [] if detects or None in gathered else gathered
        """Sinks that pack the frames themselves (a bag written by another process) take the
        frames as gathered: all of the group's, or none."""
        packed = not detects and not self.gathered_writers
        self.batch_writers = [sink.packed_batch_writer() for sink in sinks] if packed else []
        self.frame_writers = [(s.packed_writer(), s.write_batch) for s in sinks] if detects else []

    def write(
        self, data: Any, layout: FrameLayout, stamps: NDArray[Any], action_stamps: NDArray[Any]
    ) -> None:
        """Write ``len(stamps)`` frames packed back to back in ``data`` to every sink."""
        for write in self.batch_writers:
            write(data, layout, stamps, action_stamps)

    def write_each(
        self,
        data: Any,
        layout: FrameLayout,
        stamps: list[int],
        action_stamps: list[int],
        after: list[list[Record]],
    ) -> None:
        """Write each packed frame of ``data``, then its records ``after[i]``, to every sink."""
        size, view = layout.size, memoryview(data).cast("B")
        for write_frame, write_records in self.frame_writers:
            for index, (stamp, action_stamp, records) in enumerate(
                zip(stamps, action_stamps, after, strict=True)
            ):
                frame = view[index * size : (index + 1) * size]
                write_frame(frame, layout, stamp, action_stamp)  # type: ignore[arg-type]
                write_records(records)


class MessageFanout:
    """Frames in, serialised records out to every sink; each message serialised once per distro.

    Per frame the work is planned once per set of sinks (:meth:`_update_routes`): one send per
    distro, which packs the frame once per framing and hands the bytes to each sink's
    :meth:`~bubblerob_env.ros.sink.Sink.packed_writer`; sinks without framing get records.

    If every sink frames records (bags, no live sink), frames after steps are batched: up to
    ``batch_frames`` of them (and about a MiB) are gathered, then converted and packed together
    and handed to each sink's
    :meth:`~bubblerob_env.ros.sink.Sink.packed_batch_writer`. Every
    other write (records, a reset's frame, adding or removing a sink) and :meth:`flush` first
    writes the pending frames, so the bags hold the same bytes in the same order.
    ``batch_frames=0`` sends every frame at once. Close a sink only after :meth:`remove_sink`
    (or :meth:`flush`): until then its latest frames may still be in the batch.
    """

    def __init__(self, specs: EnvSpecs, topics: Topics, batch_frames: int = 256) -> None:
        if batch_frames < 0:
            raise ValueError(f"batch_frames must be >= 0 (0: no batching), got {batch_frames}")
        self.specs = specs
        self.topics = topics
        self.batch_frames = batch_frames
        self._batch: FrameBatch | None = None  # gathering frames after steps, if batching
        self._batch_sends: list[tuple[str, FramePacker, _BatchWriters]] = []
        self._serializers: dict[str, FrameSerializer] = {}
        self._sinks: dict[str, list[Sink]] = {}
        self._sends: dict[str, tuple[_Send, _Send]] = {}  # per distro: after a reset, a step
        self._plan: tuple[list[_Send], list[_Send]] = ([], [])  # every distro's sends
        self._convert: Callable[..., tuple[Any, ...]] | None = None  # frame_args
        self.detects = specs.camera is not None and topics.detections is not None
        """Whether frames carry ``/detections``: then each image goes through :attr:`detector`."""
        self.detector: Detector | None = None
        """The recogniser of the camera's images (``EpisodeStream.reset`` sets one for its env)."""

    def serializer(self, distro: str) -> FrameSerializer:
        """The serializer of ``distro`` (made on first use)."""
        if distro not in self._serializers:
            self._serializers[distro] = FrameSerializer(self.specs, distro, self.topics)
        return self._serializers[distro]

    def add_sink(self, sink: Sink) -> None:
        """Start sending to ``sink``, declaring every topic in it."""
        self.flush()  # frames gathered so far go to the sinks they were gathered for
        serializer = self.serializer(sink.distro)
        for name, msgtype, latched in serializer.topics():
            sink.add_topic(name, msgtype, latched)
        self._sinks.setdefault(sink.distro, []).append(sink)
        self._update_routes(sink.distro)  # compiles the packers now: errors before the first frame

    def remove_sink(self, sink: Sink) -> None:
        """Stop sending to ``sink`` (it is not closed), after writing the pending frames.

        The sink is removed even if writing them fails (the error is raised after).
        """
        try:
            self.flush()
        finally:
            self._sinks[sink.distro].remove(sink)
            if not self._sinks[sink.distro]:
                del self._sinks[sink.distro]
            self._update_routes(sink.distro)

    def _update_routes(self, distro: str) -> None:
        """Plan the sends of ``distro`` for its current sinks (and their current framings)."""
        sinks = self._sinks.get(distro, [])
        if sinks:
            self._sends[distro] = (self._sender(distro, False), self._sender(distro, True))
        else:
            self._sends.pop(distro, None)
        self._plan = ([s[0] for s in self._sends.values()], [s[1] for s in self._sends.values()])
        # Frame values do not depend on the distro: any converter computes them for all.
        first = next(iter(self._sends), None)
        self._convert = None if first is None else self._serializers[first].converter.frame_args
        self._plan_batches()

    def _plan_batches(self) -> None:
        """Batch frames after steps if every sink frames records (see the class docstring)."""
        self._batch, self._batch_sends = None, []
        sinks = self.sinks
        if not self.batch_frames or not sinks or any(s.framing() is None for s in sinks):
            return
        groups: dict[tuple[str, Framing], list[Sink]] = {}
        for sink in sinks:
            framing = sink.framing()
            assert framing is not None
            groups.setdefault((sink.distro, framing), []).append(sink)
        size = 1
        for (distro, framing), group in groups.items():
            packer = self._serializers[distro].packer(framing, stepped=True)
            self._batch_sends.append((distro, packer, _BatchWriters(group, self.detects)))
            size = max(size, packer.layout.size)
        # About a chunk's worth (1 MiB) at most: camera frames are ~50x larger than the rest.
        self._batch = FrameBatch(self.specs, max(1, min(self.batch_frames, 2**20 // size)))

    def flush(self) -> None:
        """Write the frames gathered for a batch to the sinks (they stay open)."""
        batch = self._batch
        if batch is None or not len(batch):
            return
        count = len(batch)
        gathered = batch.take()
        packing = [sends for sends in self._batch_sends if not sends[2].gathered_writers]
        for _, _, writers in self._batch_sends:
            for write_gathered in writers.gathered_writers:
                write_gathered(gathered, self.specs, self.topics)
        if not packing:
            return
        columns = batch.convert(gathered)
        stamps, action_stamps = columns["log_ns"], columns["action_log_ns"]
        found = self._recognise(columns["image"], count) if self.detects else None
        for distro, packer, writers in packing:
            data = packer.pack_many(columns, count)
            if found is None:
                writers.write(data, packer.layout, stamps, action_stamps)
                continue
            serializer = self._serializers[distro]
            seqs, stamp_list = columns["seq"].tolist(), stamps.tolist()
            after = [
                serializer.detections(objects, stamp, seq)
                for objects, stamp, seq in zip(found, stamp_list, seqs, strict=True)
            ]
            writers.write_each(data, packer.layout, stamp_list, action_stamps.tolist(), after)

    def _recognise(self, images: NDArray[Any], count: int) -> Sequence[Sequence[Recognised]]:
        """The objects in each of a batch's ``count`` images (rows of their bytes), at once."""
        camera = self.specs.camera
        assert camera is not None
        return self._detector().many(images.reshape(count, camera.height, camera.width, 3))

    def _sender(self, distro: str, stepped: bool) -> _Send:
        serializer = self._serializers[distro]
        groups: dict[Framing, tuple[FramePacker, list[PackedWriter]]] = {}
        plain: list[Sink] = []
        for sink in self._sinks[distro]:
            framing = sink.framing()
            if framing is None:
                plain.append(sink)
            else:
                packer = serializer.packer(framing, stepped)
                groups.setdefault(framing, (packer, []))[1].append(sink.packed_writer())
        packs = [(packer.pack_one, packer.layout, writers) for packer, writers in groups.values()]
        if len(packs) == 1 and len(packs[0][2]) == 1 and not plain:  # a recorder: one bag
            ((pack, layout, (write,)),) = packs

            def send_one(args: tuple[Any, ...], stamp: int, action_stamp: int) -> None:
                write(pack(args, stamp, action_stamp), layout, stamp, action_stamp)

            return send_one
        # Sinks that take records get them sliced from a packed frame: the first framing's, or
        # else one packed without headers.
        slicer = next(iter(groups.values()), (serializer.packer(None, stepped), []))[0]

        def send(args: tuple[Any, ...], stamp: int, action_stamp: int) -> None:
            sliced: bytes | None = None  # the first framing's bytes
            for pack, layout, writers in packs:
                data = pack(args, stamp, action_stamp)
                sliced = data if sliced is None else sliced
                for write in writers:
                    write(data, layout, stamp, action_stamp)
            if plain:
                if sliced is None:
                    sliced = slicer.pack_one(args, stamp, action_stamp)
                records = slicer.records(sliced, stamp, action_stamp)
                for sink in plain:
                    sink.write_batch(records)

        return send

    @property
    def batching(self) -> bool:
        """Whether frames after steps are gathered into batches (every sink frames records)."""
        return self._batch is not None

    @property
    def sinks(self) -> list[Sink]:
        """Every sink, in the order they were added per distro."""
        return [sink for group in self._sinks.values() for sink in group]

    def write_frame(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        stamp_ns: int,
        seq: int,
        action: NDArray[Any] | None = None,
        action_stamp_ns: int | None = None,
        reward: SupportsFloat = 0.0,
        terminated: bool = False,
        truncated: bool = False,
    ) -> None:
        """Send one frame (``action=None``: a reset) to every sink."""
        convert = self._convert
        if convert is None:
            return
        action_stamp = stamp_ns if action_stamp_ns is None else action_stamp_ns
        batch = self._batch
        if batch is not None:
            if action is not None:
                full = batch.add(
                    obs, info, stamp_ns, seq, action, action_stamp, reward, terminated, truncated
                )
                if full:
                    self.flush()
                return
            self.flush()
        args = convert(obs, info, stamp_ns, seq, action, reward, terminated, truncated)
        for send in self._plan[action is not None]:
            send(args, stamp_ns, action_stamp)
        if self.detects:
            self._write_detections(obs["camera"], stamp_ns, seq)

    def _detector(self) -> Detector:
        if self.detector is None:
            raise RuntimeError(
                "frames with a camera have /detections: set MessageFanout.detector (a "
                "bubblerob_env.vision Recogniser; EpisodeStream.reset does) or leave the "
                "topic out (Topics(detections=None))"
            )
        return self.detector

    def _write_detections(self, image: NDArray[Any], stamp_ns: int, seq: int) -> None:
        """``/detections`` of a frame's ``image``, recognised once, to every sink."""
        found = self._detector()(image)
        for distro, sinks in self._sinks.items():
            records = self._serializers[distro].detections(found, stamp_ns, seq)
            for sink in sinks:
                sink.write_batch(records)

    def write_records(self, make: Any) -> None:
        """Send records made per distro by ``make(serializer) -> list[Record]``."""
        self.flush()
        for distro, sinks in self._sinks.items():
            records = make(self._serializers[distro])
            if records:
                for sink in sinks:
                    sink.write_batch(records)
