"""Pick MuJoCo's headless EGL backend on machines without a display, whatever the import order."""

from __future__ import annotations

import os
import sys

__all__ = ["use_egl_without_display"]


def use_egl_without_display() -> None:
    """Select ``MUJOCO_GL=egl`` on Linux with no display, unless ``MUJOCO_GL`` is already set.

    MuJoCo reads ``MUJOCO_GL`` once, when it is first imported. If it was imported before this
    package (import sorters put ``mujoco`` first), its default GLFW backend would fail without a
    display, so the already-chosen context class is swapped for the EGL one as well.
    """
    if not sys.platform.startswith("linux") or "MUJOCO_GL" in os.environ:
        return
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return
    os.environ["MUJOCO_GL"] = "egl"
    gl_context = sys.modules.get("mujoco.rendering.classic.gl_context")
    if gl_context is None:
        return  # MuJoCo is not imported yet: it will read MUJOCO_GL=egl itself
    try:
        from mujoco.egl import GLContext
    except ImportError:  # no EGL on this machine: leave MuJoCo's own choice and error
        return
    gl_context.GLContext = GLContext  # type: ignore[attr-defined]
