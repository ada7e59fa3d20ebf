"""Every file a command writes, checked before any work, and written in one line's failure.

docs/RELIABILITY.md's rule for outputs: before an episode runs, a bag is read or a model trains,
each output path is checked: not a folder (or, for a folder output, not a file), a suffix the
writer knows, not another output or an input of the same command, not an existing output unless
``--overwrite`` is given (:func:`add_overwrite_option`, the same flag and words in every command),
never a recording where a file of another kind is written, and writable (its folder created and a
file opened there, then removed again: a refused command leaves nothing behind). A write that
still fails (a full disk) is one line and exit 1: :func:`write_output`.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from bubblerob_cli.errors import fail

__all__ = [
    "BAG_SUFFIXES",
    "OVERWRITE_HELP",
    "Output",
    "OutputError",
    "add_overwrite_option",
    "check_outputs",
    "require_outputs",
    "write_output",
]

BAG_SUFFIXES = (".mcap", ".db3", ".bag")
"""Storage files of recordings: never replaced by another command's output."""

OVERWRITE_HELP = "replace outputs that exist already (without it they are refused, untouched)"
"""``--overwrite``'s help, the same in every command that writes files."""

OutputKind = Literal["file", "bag", "folder", "run"]
"""``file``: one file; ``bag``: a recording (a ROS 2 bag folder or a ROS 1 ``.bag``); ``folder``:
a folder that holds the command's named outputs beside others (``record --out``); ``run``: a
folder that is the output as a whole (``train --out``), so a folder with anything in it exists."""


class OutputError(ValueError):
    """An output path that cannot be used (the message names the option, the path and why)."""


@dataclass(frozen=True)
class Output:
    """One output: its option (``--out``), the path, the suffixes its writer knows, its kind."""

    option: str
    path: Path
    suffixes: tuple[str, ...] = ()
    kind: OutputKind = "file"


def add_overwrite_option(parser: argparse.ArgumentParser) -> None:
    """``--overwrite``: the one flag, with the one help text, of every command that writes."""
    parser.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)


def _is_recording(path: Path) -> bool:
    return path.suffix.lower() in BAG_SUFFIXES


def _folder_problem(output: Output, overwrite: bool) -> str | None:
    path, option = output.path, output.option
    if path.exists() and not path.is_dir():
        return f"{option} {path} is a file: name a folder"
    if output.kind == "run" and path.is_dir() and any(path.iterdir()) and not overwrite:
        return (
            f"{option} {path} already exists and is not empty; "
            "pass --overwrite to replace the run there"
        )
    return None


def _problem(output: Output, overwrite: bool) -> str | None:
    """What is wrong with one output, or None (writability aside)."""
    path, option = output.path, output.option
    if output.kind in ("folder", "run"):
        return _folder_problem(output, overwrite)
    if output.kind == "file" and path.is_dir():
        return f"{option} {path} is a directory: name the file to write"
    if output.suffixes and path.suffix.lower() not in output.suffixes:
        return f"{option} {path}: name a {' or '.join(output.suffixes)} file"
    if (path.parent / "metadata.yaml").is_file():
        return f"{option} {path} is inside a ROS 2 bag folder: name a file outside it"
    if output.kind == "file" and path.exists() and _is_recording(path):
        return f"{option} {path} is a recording: name another file (it is never replaced)"
    if (path.exists() or path.is_symlink()) and not overwrite:
        what = "bag" if output.kind == "bag" else option
        return f"{what} {path} already exists; pass --overwrite to replace it"
    return None


def _probe(output: Output, folder: Path) -> None:
    """Open the output file (a file output) or a scratch file in ``folder``; leave no trace."""
    path = output.path
    if output.kind == "file":
        existed = path.exists()
        with path.open("ab"):
            pass
        if not existed:
            path.unlink(missing_ok=True)
        return
    handle, scratch = tempfile.mkstemp(dir=folder, prefix=".bubblerob-write-check-")
    os.close(handle)
    os.unlink(scratch)


def _writable(output: Output) -> str | None:
    """Whether the output can be written: its folders made and a file opened, then undone."""
    path = output.path
    folder = path if output.kind in ("folder", "run") else path.parent
    missing = [p for p in (folder, *folder.parents) if not p.exists()]  # deepest first
    try:
        folder.mkdir(parents=True, exist_ok=True)
        _probe(output, folder)
    except OSError as error:
        return f"{output.option} {path}: cannot be written: {error.strerror or error}"
    finally:
        for made in missing:  # the folders this check made, empty: the command makes its own
            try:
                made.rmdir()
            except OSError:
                break
    return None


def check_outputs(
    outputs: Sequence[Output | None],
    overwrite: bool = False,
    inputs: Sequence[str | os.PathLike[str]] = (),
) -> None:
    """Raise :class:`OutputError` naming the first unusable output (see the module docstring).

    ``overwrite``: the command's ``--overwrite``; ``inputs``: paths the command reads. ``None``
    entries (options not given) are skipped.
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
    overwrite: bool = False,
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
