"""Which files a bag is: a bag is a path the user names, never a guess.

A bag is a ROS 1 ``.bag`` file; an ``.mcap`` or ``.db3`` file; or a folder that is one ROS 2 bag:
one with a ``metadata.yaml`` (its storage files are the ones it lists), or one holding a single
storage file and nothing else (a recording that was killed before it wrote ``metadata.yaml``). A
folder holding several bags or other files is refused with its list. A finished bag that does not
read is *corrupt* (:class:`CorruptBagError`, naming the file and where), never "unfinished".
"""

from __future__ import annotations

import functools
from pathlib import Path

from bubblerob_env.ros.readback.mcap_scan import has_mcap_footer
from bubblerob_env.ros.readback.ros1_scan import index_position
from bubblerob_env.ros.readback.scan import CorruptBagError

__all__ = [
    "BagLayoutError",
    "CorruptBagError",
    "bag_root",
    "is_finished",
    "metadata_damage",
    "storage_file",
]

STORAGE_SUFFIXES = (".mcap", ".db3")
_SQLITE_SIDECARS = ("-journal", "-wal", "-shm")
_KINDS = "a ROS 1 .bag file, an .mcap or .db3 file, or a ROS 2 bag folder"


class BagLayoutError(OSError):
    """The path is not one bag (the message lists what is there)."""


def _listed_files(folder: Path) -> list[str] | None:
    """The storage files a ROS 2 bag folder's ``metadata.yaml`` lists, or ``None`` without one."""
    metadata = folder / "metadata.yaml"
    if not metadata.is_file():
        return None
    try:
        text = metadata.read_text(encoding="utf-8")
    except (OSError, UnicodeError) as error:
        raise CorruptBagError(f"{metadata} does not read as rosbag2 metadata ({error})") from None
    return list(_parsed_file_list(str(metadata), text))


@functools.lru_cache(maxsize=64)
def _parsed_file_list(metadata: str, text: str) -> tuple[str, ...]:
    """The storage files ``text`` (``metadata.yaml``) lists, parsed once per content.

    One command asks for a bag's layout many times, and ruamel parses 7 kB in about 40 ms.
    """
    from ruamel.yaml import YAML

    try:
        info = YAML(typ="safe").load(text)
        files = info["rosbag2_bagfile_information"]["relative_file_paths"]
        return tuple(Path(str(name)).name for name in files)
    except Exception as error:  # noqa: BLE001 - YAML, key and type errors: a damaged file
        raise CorruptBagError(f"{metadata} does not read as rosbag2 metadata ({error})") from None


def _lone_storage_file(folder: Path, beside: tuple[str, ...] = ()) -> Path | None:
    """The folder's one storage file when it holds nothing else.

    SQLite's own files (journal, WAL) and the names in ``beside`` are allowed beside it.
    """
    entries = sorted(folder.iterdir())
    storage = [p for p in entries if p.suffix in STORAGE_SUFFIXES and p.is_file()]
    if len(storage) != 1:
        return None
    allowed = {storage[0].name + suffix for suffix in ("", *_SQLITE_SIDECARS)} | set(beside)
    return storage[0] if all(p.name in allowed for p in entries) else None


def metadata_damage(folder: Path) -> str | None:
    """Why the folder's ``metadata.yaml`` does not read, or ``None`` (it reads, or is absent)."""
    try:
        _listed_files(folder)
    except CorruptBagError as error:
        return error.where
    return None


def _not_one_bag(folder: Path) -> BagLayoutError:
    entries = sorted(p.name + ("/" if p.is_dir() else "") for p in folder.iterdir())
    if not entries:
        return BagLayoutError(f"{folder} is an empty folder: it is not a bag")
    shown = ", ".join(entries[:20]) + (
        f" and {len(entries) - 20} more" if len(entries) > 20 else ""
    )
    return BagLayoutError(
        f"{folder} is not one bag: a ROS 2 bag folder holds a metadata.yaml or a single .mcap or "
        f".db3 file, and this one holds {shown}; name one bag file or bag folder"
    )


def bag_root(path: str | Path) -> Path:
    """The bag at ``path``: the ``.bag`` or storage file, or the ROS 2 bag folder it is.

    A storage file named inside a bag folder gives that folder (when the folder is that one bag).

    Raises:
        FileNotFoundError: Nothing at ``path``.
        BagLayoutError: ``path`` is not one bag (see the module docstring).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no bag at {path}")
    if path.is_dir():
        if metadata_damage(path) is not None:  # a damaged metadata.yaml beside one storage file
            if _lone_storage_file(path, ("metadata.yaml",)) is not None:
                return path  # is a bag: reading it reports the damage; recover salvages it
            _listed_files(path)  # raises, naming the damage
        if _listed_files(path) is not None or _lone_storage_file(path) is not None:
            return path
        raise _not_one_bag(path)
    if path.suffix == ".bag":
        return path
    if path.suffix not in STORAGE_SUFFIXES:
        raise BagLayoutError(f"{path} is not a bag: a bag is {_KINDS}")
    listed = _listed_files(path.parent)
    if listed is not None:
        if path.name in listed:
            return path.parent
        raise BagLayoutError(
            f"{path} is not part of the bag {path.parent}: its metadata.yaml lists "
            f"{', '.join(listed) or 'no file'}"
        )
    return path.parent if _lone_storage_file(path.parent) == path else path


def storage_file(root: Path) -> Path:
    """The file holding a bag's messages: ``root`` itself, or a ROS 2 folder's storage file."""
    if root.is_file():
        return root
    listed = None if metadata_damage(root) else _listed_files(root)
    if listed:
        return root / listed[0]
    lone = _lone_storage_file(root, ("metadata.yaml",))
    if lone is None:
        raise _not_one_bag(root)
    return lone


def is_finished(root: Path) -> bool:
    """Whether the recorder finished the bag.

    Finished: a ``metadata.yaml``, an MCAP footer, a ROS 1 index (inside the file, where the bag
    header says).

    Raises:
        CorruptBagError: The ROS 1 bag's header record is damaged.
    """
    if root.is_dir():
        return (root / "metadata.yaml").is_file()
    if root.suffix == ".bag":  # a finished bag cut short (its index gone) reads as unfinished
        return 0 < index_position(root) < root.stat().st_size
    if root.suffix == ".mcap":
        return has_mcap_footer(root)
    return False  # a lone .db3: its committed rows are read as they are
