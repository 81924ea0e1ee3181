"""colcon's entry point (ROS 2 ament_python). pip and every PEP 517 frontend use pyproject.toml instead.

colcon runs ``setup.py`` itself, and two things in pyproject.toml get in its way: its static
``[project]`` table would overrule the ament entry points below, and colcon's introspection of
``setup.py`` cannot evaluate the metadata objects setuptools makes from it. So when colcon runs this
file it describes the package from pyproject.toml's data (packages, plugin entry points) plus the
ament pieces: the ``tree`` executable under lib/mission, the ament index marker and package.xml.

The ``tree`` script is written from our own template (:data:`TREE_SCRIPT`), not setuptools' default: that
one finds its entry point through the ``mission`` distribution on the Python path, which without
``install/setup.bash`` sourced is the venv's (no ``tree`` entry point) and dies with a StopIteration
traceback. Ours says in one line to source the workspace.
"""

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from setuptools import setup

if "setuptools.build_meta" in sys.modules:  # pip / PEP 517: everything is in pyproject.toml
    setup()
else:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    from setuptools.command.develop import develop
    from setuptools.command.easy_install import ScriptWriter
    from setuptools.dist import Distribution

    TREE_SCRIPT = """# the ROS 2 executable `ros2 run mission %(name)s` starts; written by setup.py for colcon
import sys
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path


def _entry_point():
    try:
        eps = distribution(%(spec)r.partition("==")[0]).entry_points
    except PackageNotFoundError:
        return None
    return next((ep for ep in eps if ep.group == %(group)r and ep.name == %(name)r), None)


if __name__ == "__main__":
    ep = _entry_point()
    if ep is None:
        setup_bash = Path(__file__).resolve().parents[3] / "setup.bash"
        sys.stderr.write(f"%(name)s: the workspace is not sourced: run `source {setup_bash}` first "
                         "(or `ros2 run mission %(name)s` from a shell that has)\\n")
        sys.exit(2)
    sys.exit(ep.load()())
"""

    class AmentScriptWriter(ScriptWriter):
        template = TREE_SCRIPT

    def _ament_scripts(cmd, dist):  # the entry-point scripts, written from our template
        for args in AmentScriptWriter.best().get_args(dist):
            cmd.write_script(*args)

    class AmentDevelop(develop):
        def install_wrapper_scripts(self, dist):
            from setuptools.command.develop import VersionlessRequirement

            return _ament_scripts(self, VersionlessRequirement(dist))

    class AmentDistribution(Distribution):
        """Reads setup.cfg (the ament install layout) but not pyproject.toml."""

        def parse_config_files(self, filenames=None, ignore_option_errors=False):
            super().parse_config_files(filenames=["setup.cfg"], ignore_option_errors=ignore_option_errors)

    here = Path(__file__).resolve().parent
    project = tomllib.loads((here / "pyproject.toml").read_text(encoding="utf-8"))
    tool = project.get("tool", {}).get("setuptools", {})
    manifest = ET.parse(here / "package.xml").getroot()
    name = manifest.findtext("name")
    entry_points = {
        group: [f"{k} = {v}" for k, v in eps.items()]
        for group, eps in project["project"].get("entry-points", {}).items()
    }
    entry_points["console_scripts"] = ["tree = mission.ros.node:main"]
    setup(
        distclass=AmentDistribution,
        name=name,
        version=manifest.findtext("version"),
        packages=tool["packages"],
        # absolute: colcon runs this file from a build directory that links only the first-level package
        package_dir={name: str(here / folder) for name, folder in tool["package-dir"].items()},
        package_data=tool.get("package-data", {}),
        data_files=[
            ("share/ament_index/resource_index/packages", [f"resource/{name}"]),
            (f"share/{name}", ["package.xml", "mission/ros/fastdds_shm.xml"]),
        ],
        entry_points=entry_points,
        cmdclass={"develop": AmentDevelop},  # colcon --symlink-install (scripts/build_ros) runs `develop`
        zip_safe=False,
    )
