"""The DDS transport the node runs on: shared memory only, unless the operator chose otherwise.

Network rule of this project: DDS must never send on a non-loopback interface. FastDDS's defaults
(UDPv4 multicast discovery on every interface) break it, so before rclpy starts:

* ``FASTRTPS_DEFAULT_PROFILES_FILE`` unset → it is set to the package's own ``mission/ros/fastdds_shm.xml``
  (package data, so a wheel install has it too)
  (builtin transports off, one shared-memory transport of 16 MB). An operator who wants the robot's
  network sets that variable to their own profile, explicitly.
* ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` with this profile → changed to ``SYSTEM_DEFAULT``.
  Measured with Jazzy's rmw_fastrtps: LOCALHOST *adds* a UDPv4 transport on top of the profile, which
  binds UDP sockets on every interface (one on the machine's non-loopback address); SYSTEM_DEFAULT
  leaves the profile alone and the process holds no UDP or TCP socket at all.
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Mapping, MutableMapping
from pathlib import Path

PROFILE_NAME = "fastdds_shm.xml"
PACKAGE_PROFILE = Path(__file__).resolve().parent / PROFILE_NAME


def shm_profile_path() -> Path:
    """The shared-memory-only profile shipped inside the package (mission/ros/fastdds_shm.xml)."""
    return PACKAGE_PROFILE


def configure_transport(env: MutableMapping[str, str] | None = None) -> list[str]:
    """Apply the shared-memory default to `env` (os.environ) before rclpy.init; returns what was done."""
    env = os.environ if env is None else env
    notes: list[str] = []
    rmw = env.get("RMW_IMPLEMENTATION", "") or "rmw_fastrtps_cpp"
    if rmw != "rmw_fastrtps_cpp":
        return [f"DDS: RMW_IMPLEMENTATION={rmw}; its transport configuration is the operator's"]
    ours = shm_profile_path()
    if not env.get("FASTRTPS_DEFAULT_PROFILES_FILE"):
        env["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(ours)
        notes.append(f"DDS: shared memory only ({ours}); set FASTRTPS_DEFAULT_PROFILES_FILE to use another transport")
    profile = env["FASTRTPS_DEFAULT_PROFILES_FILE"]
    if Path(profile).resolve() == ours.resolve() and env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST":
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
        notes.append(
            "DDS: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST would add a UDP transport on every interface to the "
            "shared-memory profile; using SYSTEM_DEFAULT (the profile alone)"
        )
    if not Path(profile).is_file():
        notes.append(f"DDS: FASTRTPS_DEFAULT_PROFILES_FILE={profile} does not exist; FastDDS falls back to UDP")
    return notes


def private_env(domain_id: int) -> dict[str, str]:
    """The variables of a run that talks only to itself: shared memory only, on its own ROS_DOMAIN_ID.

    Tests and benchmarks start node processes with these (and set them in their own process before
    rclpy.init), so nothing leaves the machine and no other run on it hears them.
    """
    return {
        "FASTRTPS_DEFAULT_PROFILES_FILE": str(shm_profile_path()),
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "ROS_DOMAIN_ID": str(domain_id),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
    }


def package_env(setup_bash: Path, overrides: Mapping[str, str], bin_dir: Path | None = None) -> dict[str, str]:
    """The environment `ros2 run` gives a package executable: `setup_bash` sourced over os.environ
    (with `bin_dir` first on PATH), then `overrides`. Raises CalledProcessError if the script fails."""
    base = dict(os.environ)
    if bin_dir is not None:
        base["PATH"] = f"{bin_dir}{os.pathsep}{base.get('PATH', '')}"
    out = subprocess.run(
        ["bash", "-c", f"source {setup_bash} >/dev/null && env -0"], capture_output=True, env=base, check=True
    ).stdout
    env = dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)
    env.update(overrides)
    env["PYTHONUNBUFFERED"] = "1"
    return env
