"""``--action-type``: what a bare SB3 zip cannot say about itself, said by the user and checked.

Wheels and twist actions share one normalised action space, so a zip without its run's
``config.yml`` beside it (a bare zip) cannot tell which it was trained on: loading it warns
(``UncheckedPolicyWarning``). A command that drives the env with it refuses it in one line unless
``--action-type`` names the type, and that type is the env's; ``--action-type`` beside no bare zip
is refused too (an option is honoured or refused, never ignored).
"""

from __future__ import annotations

import argparse
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

from bubblerob_cli.errors import fail

__all__ = ["ACTION_TYPES", "add_action_type_option", "load_checked", "refuse_unused"]

ACTION_TYPES = ("wheels", "twist")
T = TypeVar("T")


def add_action_type_option(parser: argparse.ArgumentParser) -> None:
    """``--action-type wheels|twist``, for a bare SB3 zip."""
    parser.add_argument(
        "--action-type",
        choices=ACTION_TYPES,
        default=None,
        help="the action type a bare SB3 zip (no config.yml beside it) was trained on, which "
        "the zip cannot tell: checked against the env's; a bare zip is refused without it",
    )


def load_checked(
    command: str, name: str, env: Any, action_type: str | None, load: Callable[[], T]
) -> tuple[T, bool]:
    """``load()``'s policy, and whether it is a bare zip (its action type checked, see above).

    A bare zip without ``action_type``, or with another than ``env``'s: one line, exit 2 (``env``
    closed first). Once checked, the warning is not repeated by later loads in this process.
    """
    from policies.sb3_policy import UncheckedPolicyWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UncheckedPolicyWarning)
        policy = load()
    bare = False
    for warning in caught:
        if issubclass(warning.category, UncheckedPolicyWarning):
            bare = True
        else:  # another library's warning: shown as it would have been
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    if bare:
        problem = _mismatch(name, str(env.unwrapped.action_type), action_type)
        if problem is not None:
            env.close()
            fail(command, problem)
        warnings.filterwarnings("ignore", category=UncheckedPolicyWarning)
    return policy, bare


def _mismatch(name: str, env_type: str, action_type: str | None) -> str | None:
    if action_type is None:
        return (
            f"--policy {name} is a bare SB3 zip (no config.yml beside it): its action type cannot "
            f"be read from it; pass --action-type {env_type} if it was trained on {env_type} "
            "actions, as this env takes"
        )
    if action_type != env_type:
        return (
            f"--action-type {action_type}: the policy {name} was trained on {action_type} "
            f"actions and the env takes {env_type} (--env-kwargs "
            f'\'{{"action_type": "{action_type}"}}\')'
        )
    return None


def refuse_unused(command: str, action_type: str | None, any_bare: bool) -> None:
    """``--action-type`` given where no policy is a bare zip: one line, exit 2."""
    if action_type is not None and not any_bare:
        fail(
            command,
            f"--action-type {action_type} is for a bare SB3 zip (no config.yml beside it); "
            "no --policy is one: leave it out",
        )
