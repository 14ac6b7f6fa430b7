"""Build Nav2's nav2_msgs (the NavigateToPose action) into this virtual environment, with ROS 2's own generators.

The PyPI ROS 2 wheels have no nav2_msgs, and without it rclpy cannot read Nav2's feedback topic nor ask a goal's
result (its error code): the relay then follows a goal by its status alone (relay/backends/ros_nav2.py). A site's
sourced ROS 2 has nav2_msgs; this gives the same to a machine with only the wheels (CI, `make setup`), built the
way colcon builds it: rosidl's generators (C, the C type supports, Python; from the wheels) on Nav2 Jazzy's own
definition (relay/ros/nav2_types.py), compiled with the system's C and C++ compilers against the wheels' headers and
libraries. The libraries go to ``<venv>/lib`` (the wheels' bootstrapper puts it on ``LD_LIBRARY_PATH``), the Python
package to site-packages. Idempotent: a second run with the same definition does nothing.

Usage: ``python tools/build_nav2_msgs.py`` (``--force`` rebuilds). Needs gcc and g++ (`make setup` has them).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig
import tempfile

PACKAGE = "nav2_msgs"
#: The interface packages NavigateToPose's types use, and those rosidl's generated code includes.
DEPENDENCIES = ("geometry_msgs", "std_msgs", "builtin_interfaces", "action_msgs", "unique_identifier_msgs",
                "service_msgs", "type_description_interfaces")  # fmt: skip
RUNTIME = ("rosidl_runtime_c", "rosidl_typesupport_interface", "rcutils", "rosidl_typesupport_c",
           "rosidl_typesupport_fastrtps_c", "rosidl_typesupport_fastrtps_cpp", "rosidl_dynamic_typesupport",
           "rosidl_typesupport_introspection_c",
           "rosidl_runtime_cpp", "rmw", "fastcdr", "rcpputils")  # fmt: skip


def _generate(source: pathlib.Path, out: pathlib.Path, prefix: pathlib.Path) -> None:
    """rosidl's C, C type support (dispatch and Fast DDS) and Python generators, each into ``out/<kind>/nav2_msgs``."""
    os.environ.setdefault("AMENT_PREFIX_PATH", str(prefix))  # rosidl_generator_py looks its type supports up there
    from rosidl_generator_c.cli import GenerateC
    from rosidl_generator_py.cli import GeneratePython
    from rosidl_typesupport_c.cli import GenerateCTypesupport
    from rosidl_typesupport_fastrtps_c.cli import GenerateFastRTPSCTypesupport
    from rosidl_typesupport_introspection_c.cli import GenerateIntrospectionCTypesupport

    # The extensions themselves, not `rosidl generate`: the wheels install each one's entry points twice (an
    # egg-info beside the dist-info), which rosidl's command refuses as duplicates.
    for kind, extension in (("c", GenerateC("c")), ("fastrtps_c", GenerateFastRTPSCTypesupport("fastrtps_c")),
                            ("typesupport_c", GenerateCTypesupport("c")), ("py", GeneratePython("py")),
                            ("introspection_c", GenerateIntrospectionCTypesupport("introspection_c"))):  # fmt: skip
        extension.generate(
            package_name=PACKAGE,
            interface_files=[f"{source}:action/NavigateToPose.action"],
            include_paths=[str(prefix / "share")],
            output_path=out / kind / PACKAGE,
        )


def _compile(out: pathlib.Path, prefix: pathlib.Path, site: pathlib.Path) -> None:
    lib = prefix / "lib"
    includes = [f"-I{out / kind}" for kind in ("c", "fastrtps_c", "typesupport_c", "py", "introspection_c")]
    includes += [f"-I{prefix / 'include' / name}" for name in (*DEPENDENCIES, *RUNTIME)]
    import numpy  # the Python side's arrays (rosidl_generator_py)

    includes += [f"-I{prefix / 'include'}", f"-I{sysconfig.get_paths()['include']}", f"-I{numpy.get_include()}"]
    common = ["-shared", "-fPIC", "-O2", f"-L{lib}", f"-Wl,-rpath,{lib}", *includes]
    c = out / "c" / PACKAGE / "action"
    py = out / "py" / PACKAGE

    def build(compiler: str, name: str, sources: list[pathlib.Path], libraries: list[str]) -> None:
        target = lib / name
        command = [compiler, *common, *(str(s) for s in sources), "-o", str(target), *(f"-l{x}" for x in libraries)]
        subprocess.run(command, check=True)

    deps_c = [f"{d}__rosidl_generator_c" for d in DEPENDENCIES]
    build("gcc", f"lib{PACKAGE}__rosidl_generator_c.so", sorted((c / "detail").glob("*.c")),
          [*deps_c, "rosidl_runtime_c", "rcutils"])  # fmt: skip
    build("g++", f"lib{PACKAGE}__rosidl_typesupport_fastrtps_c.so",
          sorted((out / "fastrtps_c" / PACKAGE / "action" / "detail").glob("*.cpp")),
          [f"{PACKAGE}__rosidl_generator_c", *(f"{d}__rosidl_typesupport_fastrtps_c" for d in DEPENDENCIES), *deps_c,
           "rosidl_typesupport_fastrtps_c", "rosidl_typesupport_fastrtps_cpp", "fastcdr", "rosidl_runtime_c",
           "rcutils"])  # fmt: skip
    build("g++", f"lib{PACKAGE}__rosidl_typesupport_c.so",
          sorted((out / "typesupport_c" / PACKAGE / "action").glob("*.cpp")),
          [f"{PACKAGE}__rosidl_generator_c", *(f"{d}__rosidl_typesupport_c" for d in DEPENDENCIES), *deps_c,
           "rosidl_typesupport_c", "rosidl_runtime_c", "rcpputils", "rcutils"])  # fmt: skip
    # Services' introspection (their event messages, ROS 2 Jazzy on) asks this one: without it GetResult failed.
    build("gcc", f"lib{PACKAGE}__rosidl_typesupport_introspection_c.so",
          sorted((out / "introspection_c" / PACKAGE / "action" / "detail").glob("*.c")),
          [f"{PACKAGE}__rosidl_generator_c", *(f"{d}__rosidl_typesupport_introspection_c" for d in DEPENDENCIES),
           *deps_c, "rosidl_runtime_c", "rcutils"])  # fmt: skip
    build("gcc", f"lib{PACKAGE}__rosidl_generator_py.so", sorted((py / "action").glob("*_s.c")),
          [f"{PACKAGE}__rosidl_generator_c", *(f"{d}__rosidl_generator_py" for d in DEPENDENCIES),
           *deps_c, "rosidl_runtime_c", "rcutils"])  # fmt: skip
    package = site / PACKAGE
    (package / "action").mkdir(parents=True, exist_ok=True)
    entry = py / f"_{PACKAGE}_s.ep.rosidl_typesupport_c.c"
    subprocess.run(
        ["gcc", *common, str(entry), "-o", str(package / f"{PACKAGE}_s__rosidl_typesupport_c.so"),
         f"-l{PACKAGE}__rosidl_generator_py", f"-l{PACKAGE}__rosidl_typesupport_c", f"-l{PACKAGE}__rosidl_generator_c",
         "-lrosidl_typesupport_c", "-lrosidl_runtime_c", "-lrcutils"],
        check=True,
    )  # fmt: skip
    for source in (py / "action").glob("*.py"):
        shutil.copyfile(source, package / "action" / source.name)
    (package / "__init__.py").write_text("")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if this definition was built already")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
    from relay.ros.nav2_types import NAVIGATE_TO_POSE_ACTION

    prefix = pathlib.Path(sys.prefix)
    site = pathlib.Path(sysconfig.get_paths()["purelib"])
    stamp = site / PACKAGE / ".built"
    digest = hashlib.sha256(NAVIGATE_TO_POSE_ACTION.encode()).hexdigest()
    if not args.force and stamp.exists() and stamp.read_text() == digest:
        print(f"{PACKAGE}: built already ({site / PACKAGE})")  # noqa: T201 - a command-line tool's report
        return 0
    if not (prefix / "include" / "rosidl_runtime_c").is_dir():
        missing = f"{PACKAGE}: the ROS 2 wheels are not installed in {prefix} (`pip install '.[ros]'`)"
        print(missing, file=sys.stderr)  # noqa: T201 - a command-line tool's report
        return 1
    with tempfile.TemporaryDirectory(prefix="nav2_msgs-") as work:
        source = pathlib.Path(work) / "src"
        (source / "action").mkdir(parents=True)
        (source / "action" / "NavigateToPose.action").write_text(NAVIGATE_TO_POSE_ACTION)
        out = pathlib.Path(work) / "out"
        _generate(source, out, prefix)
        _compile(out, prefix, site)
    stamp.write_text(digest)
    print(f"{PACKAGE}: built into {site / PACKAGE} and {prefix / 'lib'}")  # noqa: T201 - a command-line tool's report
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
