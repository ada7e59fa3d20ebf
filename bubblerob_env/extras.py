"""Which optional extra a command needs, and a one-line message when it is not installed.

The requirements of each extra are read from the installed package's metadata (pyproject's
``[project.optional-dependencies]``), so this module never repeats them.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import metadata

__all__ = ["MissingExtraError", "missing_requirements", "require_extra"]

_DIST = "bubblerob"
_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(\[([^\]]*)\])?")
_EXTRA_MARKER = re.compile(r"""extra\s*==\s*["']([^"']+)["']""")


class MissingExtraError(SystemExit):
    """Raised (as a ``SystemExit`` with a one-line message) when an extra is not installed."""


def _normalize(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


@cache
def _requirements(extra: str) -> tuple[str, ...]:
    """Distribution names that ``bubblerob[extra]`` installs (its own extras expanded)."""
    try:
        requires = metadata.requires(_DIST) or []
    except metadata.PackageNotFoundError:
        return ()  # running from a source tree that was never installed: nothing to check
    names: list[str] = []
    for requirement in requires:
        requirement_part, _, marker = requirement.partition(";")
        found = _EXTRA_MARKER.search(marker)
        if found is None or found.group(1) != extra:
            continue
        match = _NAME.match(requirement_part)
        if match is None or not _applies(marker, extra):
            continue
        name = _normalize(match.group(1))
        if name == _DIST:
            for inner in (match.group(3) or "").split(","):
                if inner.strip():
                    names.extend(_requirements(inner.strip()))
        else:
            names.append(name)
    return tuple(dict.fromkeys(names))


def _applies(marker: str, extra: str) -> bool:
    """Whether a requirement's marker (e.g. ``python_version < '3.14'``) holds here."""
    if not _EXTRA_MARKER.sub("", marker).strip(" ()and"):
        return True  # only the extra clause
    try:
        from packaging.markers import Marker
    except ModuleNotFoundError:
        return False  # cannot tell: do not call it missing
    return bool(Marker(marker).evaluate({"extra": extra}))


def missing_requirements(extra: str) -> list[str]:
    """The requirements of ``bubblerob[extra]`` that are not installed."""
    missing = []
    for name in _requirements(extra):
        try:
            metadata.distribution(name)
        except metadata.PackageNotFoundError:
            missing.append(name)
    return missing


def require_extra(extra: str, command: str) -> None:
    """Exit with one line naming the extra to install if ``bubblerob[extra]`` is incomplete."""
    missing = missing_requirements(extra)
    if missing:
        raise MissingExtraError(
            f"{command} needs the [{extra}] extra: pip install 'bubblerob[{extra}]' "
            f"(missing: {', '.join(missing)})"
        )
