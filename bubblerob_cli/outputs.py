"""Every file a command writes, checked before any work, and written in one line's failure.

docs/RELIABILITY.md's rule for outputs: before an episode runs, a bag is read or a model trains,
each output path is checked: not a folder, a suffix the writer knows, not another output or an
input of the same command, not an existing file unless ``--overwrite`` is given (a command without
``--overwrite`` still never replaces a recording: a bag file, nor writes into a ROS 2 bag folder),
and writable (its folder is created and a file opened there). A write that still fails (a full
disk) is one line and exit 1: :func:`write_output`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from bubblerob_cli.errors import fail

__all__ = [
    "BAG_SUFFIXES",
    "Output",
    "OutputError",
    "check_outputs",
    "require_outputs",
    "write_output",
]

BAG_SUFFIXES = (".mcap", ".db3", ".bag")
"""Storage files of recordings: never replaced by another command's output."""


class OutputError(ValueError):
    """An output path that cannot be used (the message names the option, the path and why)."""


@dataclass(frozen=True)
class Output:
    """One output option: its flag (``--out``), the path given, the suffixes its writer knows."""

    option: str
    path: Path
    suffixes: tuple[str, ...]


def _is_recording(path: Path) -> bool:
    return path.suffix.lower() in BAG_SUFFIXES


def _problem(output: Output, overwrite: bool | None) -> str | None:
    """What is wrong with one output, or None (writability aside)."""
    path, option = output.path, output.option
    if path.is_dir():
        return f"{option} {path} is a directory: name the file to write"
    if output.suffixes and path.suffix.lower() not in output.suffixes:
        return f"{option} {path}: name a {' or '.join(output.suffixes)} file"
    if (path.parent / "metadata.yaml").is_file():
        return f"{option} {path} is inside a ROS 2 bag folder: name a file outside it"
    if path.exists() and _is_recording(path):
        return f"{option} {path} is a recording: name another file (it is never replaced)"
    if path.exists() and overwrite is False:
        return f"{option} {path} exists: pass --overwrite to replace it"
    return None


def _writable(output: Output) -> str | None:
    """Create the folder and open the file for appending (removed again if it was new)."""
    path = output.path
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("ab"):
            pass
    except OSError as error:
        return f"{output.option} {path} cannot be written: {error.strerror or error}"
    if not existed:
        path.unlink(missing_ok=True)
    return None


def check_outputs(
    outputs: Sequence[Output | None],
    overwrite: bool | None = None,
    inputs: Sequence[str | os.PathLike[str]] = (),
) -> None:
    """Raise :class:`OutputError` naming the first unusable output (see the module docstring).

    ``overwrite``: the command's ``--overwrite`` (None: it has none, and an existing file that is
    no recording is replaced, as before); ``inputs``: paths the command reads. ``None`` entries
    (options not given) are skipped.
    """
    given = [output for output in outputs if output is not None]
    seen: dict[Path, str] = {Path(p).resolve(): "the input" for p in inputs}
    for output in given:
        resolved = output.path.resolve()
        if resolved in seen:
            raise OutputError(
                f"{output.option} {output.path} is also {seen[resolved]}: name another file"
            )
        seen[resolved] = output.option
        problem = _problem(output, overwrite) or _writable(output)
        if problem is not None:
            raise OutputError(problem)


def require_outputs(
    command: str,
    outputs: Sequence[Output | None],
    overwrite: bool | None = None,
    inputs: Sequence[str | os.PathLike[str]] = (),
) -> None:
    """:func:`check_outputs`, or one line ``bubblerob COMMAND: ...`` and exit 2."""
    try:
        check_outputs(outputs, overwrite, inputs)
    except OutputError as error:
        fail(command, str(error))


def write_output(command: str, option: str, path: Path, write: Callable[[Path], object]) -> None:
    """``write(path)``; an ``OSError`` (a full disk, a folder gone) is one line and exit 1."""
    try:
        write(path)
    except OSError as error:
        fail(command, f"cannot write {option} {path}: {error.strerror or error}", status=1)
