"""What reading a bag's records in file order found: topics, messages, and where it stopped."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["CorruptBagError", "Message", "Scan"]

Message = tuple[int, int, bytes]
"""``(connection id, log time ns, serialised message)``."""


@dataclass
class Scan:
    """Records read in file order up to the end, a record cut short, or the first damage."""

    topics: dict[int, tuple[str, str]] = field(default_factory=dict)
    """``connection id -> (topic, message type)``."""
    messages: list[Message] = field(default_factory=list)
    damage: str | None = None
    """The first damaged record in words (file and byte offset), or ``None``."""
    cut_short: bool = False
    """The file ends inside a record (a killed recording)."""
    cut_at: int | None = None
    """Where the record that runs past the end of the file starts, when ``cut_short``."""
    data_end: bool = False
    """The end of the data section was reached (MCAP's ``DataEnd``, a ROS 1 bag's index)."""


class CorruptBagError(OSError):
    """A bag's bytes are damaged (the message names the file and where)."""

    def __init__(self, where: str) -> None:
        # One line: readers quote whole message definitions in their errors.
        where = " ".join(where.split())
        where = where if len(where) <= 300 else where[:297] + "..."
        super().__init__(f"corrupt bag: {where}")
        self.where = where
