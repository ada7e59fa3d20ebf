"""Build ROS 2 message packages that have no wheel (``tf2_msgs``) into a pip-installed ROS 2.

The ``ros-jazzy-*`` wheels on the Python package index bring rclpy and most message packages, but
not ``tf2_msgs``, whose ``TFMessage`` ``/tf`` and ``/tf_static`` carry. They do bring the rosidl
toolchain ROS 2 builds every message package with (``rosidl_adapter``, the C and Python
generators, the type-description hasher and the C, Fast DDS and introspection type supports,
with their templates, headers and libraries). This module runs that toolchain exactly as
``rosidl_generate_interfaces`` does in a colcon build, on the genuine ``.msg``
(``geometry_msgs/TransformStamped[] transforms``, the same in ROS 1 and ROS 2), compiles the
generated C/C++ with the system compiler, and installs the result into the environment's prefix
laid out like the wheels' own packages::

    <prefix>/lib/libtf2_msgs__rosidl_{generator_c,generator_py,typesupport_c,...}.so
    <prefix>/lib/python3.X/site-packages/tf2_msgs/{msg/,tf2_msgs_s__rosidl_typesupport_*.so}
    <prefix>/include/tf2_msgs/tf2_msgs/msg/...      <prefix>/share/tf2_msgs/msg/TFMessage.*
    <prefix>/share/ament_index/resource_index/{packages,rosidl_interfaces}/tf2_msgs

Only the message is built (not tf2_msgs' ``FrameGraph`` service or ``LookupTransform`` action,
which the node does not use). The type hash is rosidl's, so the DDS type name
(``tf2_msgs::msg::dds_::TFMessage_``) and hash match every ROS 2 Jazzy tf2 node.

Run it with the environment's interpreter (needs ``gcc``/``g++`` and Python's headers)::

    .venv-ros2/bin/python -m bubblerob_env.ros.live.ros2_msgs

(the command is :mod:`bubblerob_cli.ros2_msgs`; this package is the library it calls).
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["MSG_DIR", "PACKAGES", "TYPESUPPORTS", "build_package"]

PACKAGES: dict[str, dict[str, Any]] = {
    "tf2_msgs": {
        "messages": ["TFMessage"],
        "depends": ["geometry_msgs", "std_msgs", "builtin_interfaces"],
    },
    # /detections' Detection2DArray and its parts (vision_msgs 4.1.1, Jazzy's release; no wheel).
    "vision_msgs": {
        "messages": [
            "Point2D",
            "Pose2D",
            "BoundingBox2D",
            "ObjectHypothesis",
            "ObjectHypothesisWithPose",
            "Detection2D",
            "Detection2DArray",
        ],
        "depends": ["geometry_msgs", "std_msgs", "builtin_interfaces"],
    },
}
"""Packages this module can build: their messages and the message packages they depend on."""
MSG_DIR = Path(__file__).resolve().parents[2] / "messages" / "msg"
"""Where the genuine ``.msg`` files are (shared with the ROS 1 definitions: identical here)."""
TYPESUPPORTS = ("rosidl_typesupport_fastrtps_c", "rosidl_typesupport_introspection_c")


def _generate(prefix: Path, package: str, idl_dir: Path, out: Path) -> None:
    """Run rosidl's generators (``rosidl generate``'s API) for ``package`` into ``out/<kind>``."""
    import rosidl_cli.entry_points as entry_points  # type: ignore[import-not-found,unused-ignore]

    # The wheels register each rosidl extension twice (egg-info and dist-info): not an error.
    original = entry_points.get_entry_points

    def lenient(group: str, *, specs: Any = None, strict: bool = False) -> Any:
        return original(group, specs=specs, strict=False)

    entry_points.get_entry_points = lenient
    logging.getLogger("rosidl_cli").setLevel(logging.ERROR)
    from rosidl_cli.command.generate.api import (  # type: ignore[import-not-found,unused-ignore]
        generate,
    )

    files = [f"{idl_dir}:msg/{name}.idl" for name in PACKAGES[package]["messages"]]
    include = [str(prefix / "share")]
    for kind, types, supports in [
        ("c", ["c"], []),
        ("py", ["py"], []),
        ("typesupport_c", [], ["c"]),
        ("fastrtps_c", [], ["fastrtps_c"]),
        ("introspection_c", [], ["introspection_c"]),
    ]:
        generate(
            package_name=package,
            interface_files=files,
            include_paths=include,
            output_path=out / kind / package,
            types=types,
            typesupports=supports,
        )


def _compile(
    sources: list[Path], output: Path, includes: list[Path], libs: list[str], prefix: Path
) -> None:
    """Compile and link ``sources`` into the shared object ``output`` (C or C++ by suffix)."""
    cxx = any(s.suffix == ".cpp" for s in sources)
    compiler = os.environ.get("CXX", "g++") if cxx else os.environ.get("CC", "gcc")
    command = [compiler, "-shared", "-fPIC", "-O2", "-w"]
    command += ["-std=c++17"] if cxx else ["-std=c11"]
    command += [f"-I{i}" for i in includes]
    command += [str(s) for s in sources]
    command += ["-o", str(output), f"-L{prefix / 'lib'}", f"-L{output.parent}"]
    command += [f"-l{lib}" for lib in libs]
    command += [f"-Wl,-rpath,{prefix / 'lib'}"]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise RuntimeError(f"compiling {output.name} failed:\n{' '.join(command)}\n{result.stderr}")


def _sources(gen: Path, package: str, kind: str, pattern: str) -> list[Path]:
    """The generated files of ``kind`` that match ``pattern`` (none: the generator failed)."""
    found = sorted((gen / kind / package).rglob(pattern))
    if not found:
        raise RuntimeError(f"rosidl generated no {pattern} for {kind}")
    return found


def _includes(prefix: Path, gen: Path) -> list[Path]:
    """The header folders: the generated ones, the prefix's, Python's and NumPy's."""
    includes = [gen / kind for kind in ("c", "typesupport_c", "fastrtps_c", "introspection_c")]
    includes += [prefix / "include"]
    includes += [p for p in sorted((prefix / "include").iterdir()) if p.is_dir()]
    includes += [Path(sysconfig.get_paths()["include"])]
    import numpy

    includes.append(Path(numpy.get_include()))
    return includes


def _compile_libraries(
    package: str, prefix: Path, gen: Path, build: Path, includes: list[Path]
) -> None:
    """Compile the package's C libraries into ``build``: generator, type supports, Python's."""
    deps = PACKAGES[package]["depends"]
    gen_c = f"{package}__rosidl_generator_c"
    _compile(
        _sources(gen, package, "c", "*.c"),
        build / f"lib{gen_c}.so",
        includes,
        [f"{d}__rosidl_generator_c" for d in deps] + ["rosidl_runtime_c", "rcutils"],
        prefix,
    )
    for ts, pattern, extra in [
        ("rosidl_typesupport_introspection_c", "*.c", ["rosidl_typesupport_introspection_c"]),
        (
            "rosidl_typesupport_fastrtps_c",
            "*.cpp",
            ["rosidl_typesupport_fastrtps_c", "rosidl_typesupport_fastrtps_cpp", "fastcdr"],
        ),
    ]:
        kind = ts.removeprefix("rosidl_typesupport_")
        _compile(
            _sources(gen, package, kind, pattern),
            build / f"lib{package}__{ts}.so",
            includes,
            [gen_c, *(f"{d}__{ts}" for d in deps), *extra, "rosidl_runtime_c", "rcutils"],
            prefix,
        )
    _compile(
        _sources(gen, package, "typesupport_c", "*.cpp"),
        build / f"lib{package}__rosidl_typesupport_c.so",
        includes,
        [gen_c, "rosidl_typesupport_c", "rosidl_runtime_c", "rcutils", "rcpputils"],
        prefix,
    )
    _compile(
        _sources(gen, package, "py", "*_s.c"),
        build / f"lib{package}__rosidl_generator_py.so",
        includes,
        [gen_c, *(f"{d}__rosidl_generator_py" for d in deps), "rosidl_runtime_c"],
        prefix,
    )


def _compile_extensions(
    package: str, prefix: Path, gen: Path, build: Path, includes: list[Path]
) -> dict[str, Path]:
    """Compile the Python extension of each type support into ``build``: by file name."""
    gen_c, gen_py = f"{package}__rosidl_generator_c", f"{package}__rosidl_generator_py"
    extensions = {}
    for ts in ("rosidl_typesupport_c", *TYPESUPPORTS):
        name = f"{package}_s__{ts}.so"
        _compile(
            [gen / "py" / package / f"_{package}_s.ep.{ts}.c"],
            build / name,
            includes,
            [gen_py, f"{package}__{ts}", gen_c, "rosidl_runtime_c"],
            prefix,
        )
        extensions[name] = build / name
    return extensions


def _install(package: str, prefix: Path, work: Path, extensions: dict[str, Path]) -> Path:
    """Install the build in ``work`` into ``prefix``, laid out as the wheels' message packages."""
    messages = PACKAGES[package]["messages"]
    msg_dir, idl_dir, gen, build = work / "src" / "msg", work / "idl", work / "gen", work / "lib"
    for so in build.glob("lib*.so"):
        shutil.copy(so, prefix / "lib" / so.name)
    target = Path(sysconfig.get_paths(vars={"base": str(prefix)})["purelib"]) / package
    if target.exists():
        shutil.rmtree(target)
    (target / "msg").mkdir(parents=True)
    (target / "__init__.py").write_text("")
    for py in (gen / "py" / package / "msg").glob("*.py"):
        shutil.copy(py, target / "msg" / py.name)
    for name, path in extensions.items():
        shutil.copy(path, target / name)
    headers = prefix / "include" / package / package
    if headers.exists():
        shutil.rmtree(headers)
    for kind in ("c", "typesupport_c", "fastrtps_c", "introspection_c"):
        shutil.copytree(gen / kind / package, headers, dirs_exist_ok=True)
    share = prefix / "share" / package / "msg"
    share.mkdir(parents=True, exist_ok=True)
    for name in messages:
        shutil.copy(msg_dir / f"{name}.msg", share)
        shutil.copy(idl_dir / "msg" / f"{name}.idl", share)
        for found in gen.rglob(f"{name}.json"):
            shutil.copy(found, share)
            break
    index = prefix / "share" / "ament_index" / "resource_index"
    for kind, text in [
        ("packages", ""),
        ("rosidl_interfaces", "\n".join(f"msg/{n}.{e}" for n in messages for e in ("idl", "msg"))),
    ]:
        (index / kind).mkdir(parents=True, exist_ok=True)
        (index / kind / package).write_text(text)
    return target


def build_package(package: str = "tf2_msgs", prefix: Path | None = None) -> Path:
    """Generate, compile and install ``package`` into ``prefix`` (default: ``sys.prefix``).

    Returns the installed Python package directory.

    Raises:
        RuntimeError: The rosidl toolchain is missing or a compiler failed.
    """
    prefix = Path(prefix or sys.prefix).resolve()
    spec = PACKAGES[package]
    try:
        from rosidl_adapter.msg import (  # type: ignore[import-not-found,unused-ignore]
            convert_msg_to_idl,
        )
    except ImportError as error:
        raise RuntimeError(
            f"rosidl is not importable ({error}): pip install ros-jazzy-rclpy (it brings rosidl)"
        ) from None
    os.environ.setdefault("AMENT_PREFIX_PATH", str(prefix))
    with tempfile.TemporaryDirectory(prefix=f"{package}-build-") as tmp:
        work = Path(tmp)
        msg_dir, idl_dir, gen, build = (
            work / "src" / "msg",
            work / "idl",
            work / "gen",
            work / "lib",
        )
        msg_dir.mkdir(parents=True)
        (idl_dir / "msg").mkdir(parents=True)
        for name in spec["messages"]:
            shutil.copy(MSG_DIR / package / f"{name}.msg", msg_dir)
            convert_msg_to_idl(work / "src", package, Path(f"msg/{name}.msg"), idl_dir / "msg")
        _generate(prefix, package, idl_dir, gen)
        includes = _includes(prefix, gen)
        build.mkdir()
        _compile_libraries(package, prefix, gen, build, includes)
        extensions = _compile_extensions(package, prefix, gen, build, includes)
        return _install(package, prefix, work, extensions)
