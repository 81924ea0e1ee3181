"""The wheel, as a pip user gets it: built from the sources, installed with its [ros] extra into a fresh
venv outside the checkout, and run from yet another directory.

* pyproject.toml's explicit ``packages`` list names every package folder under the mapped roots, so a
  new subpackage cannot be left out of the wheel silently;
* the wheel holds every module of every listed package and everything a run needs at run time (tree
  XML, scenarios, configs, the live view's static files, the DDS profiles), under the one top-level
  name ``mission``: no ``sim``, ``trees``, ``behaviours``, ``perception_plugins``, ``bench`` or ``tools``;
* installed, ``mission plugins`` lists the entry points and a 10 s ``mission run`` exits as a mission
  run does (0 succeeded / 1 failed, with its report);
* ``mission tree --tree none`` runs on the shared-memory DDS profile shipped inside that venv's
  site-packages (the node chooses it: FASTRTPS_DEFAULT_PROFILES_FILE is unset), holds no UDP/TCP socket
  beyond loopback, and stops cleanly on SIGINT.

Nothing here sends beyond loopback except pip fetching packages; the node runs on a private
ROS_DOMAIN_ID (tests/helpers/ros_env.py) and only after the profile it will pick is known to be in the venv.
The venv (~1 GB, in /dev/shm when there is room) is removed at the end; pip's cache keeps downloads.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.helpers.ros_env import DOMAIN_ID, NodeProcess, inet_sockets, wait_for
from tools.import_contracts import declared_packages, package_dir, package_folders

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
NOT_INSTALLED = ("sim", "trees", "behaviours", "perception_plugins", "bench", "tools")
# What a run reads at run time, by where it lives in the sources → where it must be in the wheel.
RUN_TIME_DATA = {
    "trees/*.xml": "mission/trees",
    "trees/examples/*.xml": "mission/trees/examples",
    "sim/scenarios/*.yaml": "mission/sim/scenarios",
    "mission/configs/*.yaml": "mission/configs",
    "mission/viz/static/*": "mission/viz/static",
    "mission/ros/*.xml": "mission/ros",
}
SCENARIO = "explore_dock"  # ~3 s of wall time for 10 simulated seconds
# A user's shell: nothing of the checkout's venv (PATH, LD_LIBRARY_PATH, the ROS wheels' re-exec guard,
# PYTHONPATH, the tests' DDS variables); pip's settings pass, so it finds packages as the developer's does.
PASS_THROUGH = {
    "HOME",
    "USER",
    "LOGNAME",
    "LANG",
    "LC_ALL",
    "LC_CTYPE",
    "TERM",
    "TMPDIR",
    "CI",
    "SSL_CERT_FILE",
    "SSL_CERT_DIR",
    "REQUESTS_CA_BUNDLE",
    "HTTP_PROXY",
    "HTTPS_PROXY",
    "NO_PROXY",
    "http_proxy",
    "https_proxy",
    "no_proxy",
}


def user_env(bin_dir: Path | None = None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k in PASS_THROUGH or k.startswith("PIP_")}
    env["PATH"] = os.pathsep.join([*([str(bin_dir)] if bin_dir else []), "/usr/local/bin", "/usr/bin", "/bin"])
    env.update(PIP_NO_INPUT="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONUNBUFFERED="1")
    return env


def run(cmd: list[str | Path], cwd: Path, env: dict[str, str], timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(c) for c in cmd],
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def checked(proc: subprocess.CompletedProcess[str], what: str) -> subprocess.CompletedProcess[str]:
    assert proc.returncode == 0, f"{what} exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


def source_files() -> list[Path]:
    """The files a clean clone has (tracked, plus untracked ones not ignored): no .venv, build/, install/."""
    proc = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        check=False,
    )
    if proc.returncode == 0:
        return sorted({ROOT / name for name in proc.stdout.decode().split("\0") if name})
    skip = {".git", ".venv", "build", "install", "log", "out", "__pycache__", ".pytest_cache", ".ruff_cache"}
    return sorted(p for p in ROOT.rglob("*") if p.is_file() and not skip & set(p.relative_to(ROOT).parts))


def outside_checkout(path: Path) -> Path:
    assert not path.resolve().is_relative_to(ROOT), f"{path} is inside the checkout"
    return path


# ---------------------------------------------------------------------------------------------- the list


def test_the_packages_list_names_every_package_folder_under_the_mapped_roots():
    listed = set(declared_packages())
    on_disk = package_folders()
    assert not on_disk - listed, f"package folders missing from pyproject.toml's packages: {sorted(on_disk - listed)}"
    assert not listed - on_disk, f"listed packages with no folder + __init__.py: {sorted(listed - on_disk)}"
    assert {"mission", "mission.core", "mission.trees", "mission.sim"} <= listed


def test_package_folders_sees_a_nested_subpackage_and_ignores_data_folders(tmp_path):
    """The comparison above can fail: a new folder with __init__.py is found, data folders are not."""
    (tmp_path / "mission" / "configs").mkdir(parents=True)
    (tmp_path / "plugins" / "vlm" / "data").mkdir(parents=True)
    for pkg in ("mission", "plugins", "plugins/vlm"):
        (tmp_path / pkg / "__init__.py").write_text("")
    (tmp_path / "pyproject.toml").write_text(
        '[tool.setuptools]\npackages = ["mission", "mission.plugins"]\n'
        '[tool.setuptools.package-dir]\n"mission.plugins" = "plugins"\n'
    )
    assert package_folders(tmp_path / "pyproject.toml") == {"mission", "mission.plugins", "mission.plugins.vlm"}
    assert package_dir("mission.plugins.vlm", tmp_path / "pyproject.toml") == tmp_path / "plugins" / "vlm"


# --------------------------------------------------------------------------------------------- the wheel


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """`pip wheel --no-deps` of a clean copy of the sources (the checkout gets no build/ or egg-info)."""
    base = outside_checkout(tmp_path_factory.mktemp("wheel-build"))
    src = base / "src"
    for f in source_files():
        if f.is_file():
            dest = src / f.relative_to(ROOT)
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, dest)
    checked(
        run(
            [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", base / "dist", src],
            base,
            user_env(),
            timeout=300,
        ),
        "pip wheel",
    )
    (built,) = (base / "dist").glob("mission-*.whl")
    return built


def wheel_names(wheel: Path) -> set[str]:
    with zipfile.ZipFile(wheel) as z:
        return {n for n in z.namelist() if not n.endswith("/")}


@pytest.mark.wheel
def test_the_wheel_holds_every_module_of_every_listed_package(wheel):
    names = wheel_names(wheel)
    missing = []
    for package in declared_packages():
        for module in package_dir(package).glob("*.py"):
            name = "/".join([*package.split("."), module.name])
            if name not in names:
                missing.append(name)
    assert not missing, f"modules not in the wheel: {missing}"
    assert "mission/trees/loader.py" in names and "mission/sim/scene.py" in names and "mission/core/se3.py" in names
    # what only tests, bench and tools use stays in the checkout (tools/)
    assert not {"mission/perception_plugins/synthetic_views.py", "mission/viz/browser.py"} & names


@pytest.mark.wheel
def test_the_wheel_holds_what_a_run_reads_at_run_time(wheel):
    names = wheel_names(wheel)
    expected = {
        f"{dest}/{f.name}" for pattern, dest in RUN_TIME_DATA.items() for f in ROOT.glob(pattern) if f.is_file()
    }
    assert not expected - names, f"run-time data not in the wheel: {sorted(expected - names)}"
    for essential in (
        "mission/ros/fastdds_shm.xml",
        "mission/trees/mission.xml",
        f"mission/sim/scenarios/{SCENARIO}.yaml",
        "mission/viz/static/page.html",
    ):
        assert essential in names
    with zipfile.ZipFile(wheel) as z:
        assert z.read("mission/ros/fastdds_shm.xml") == (ROOT / "mission/ros/fastdds_shm.xml").read_bytes()


@pytest.mark.wheel
def test_the_wheel_installs_one_top_level_name_mission(wheel):
    names = wheel_names(wheel)
    dist_info = f"mission-{PYPROJECT['project']['version']}.dist-info/"
    outside = sorted(n for n in names if not n.startswith(("mission/", dist_info)))
    assert not outside, f"files outside mission/: {outside}"
    with zipfile.ZipFile(wheel) as z:
        assert z.read(dist_info + "top_level.txt").decode().split() == ["mission"]
        entry_points = z.read(dist_info + "entry_points.txt").decode()
    assert "mission = mission.cli:main" in entry_points


# ------------------------------------------------------------------------------------- installed, elsewhere


class Installed:
    """A fresh venv with the wheel and its [ros] extra, and an empty directory to run it from."""

    def __init__(self, venv: Path, workdir: Path) -> None:
        self.venv = venv
        self.bin = venv / "bin"
        self.workdir = workdir
        self.env = user_env(self.bin)

    def python(self, code: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
        return run([self.bin / "python", "-c", code], self.workdir, self.env, timeout)

    def mission(self, *args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
        return run([self.bin / "mission", *args], self.workdir, self.env, timeout)


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Iterator[Installed]:
    base = outside_checkout(tmp_path_factory.mktemp("wheel-install"))
    venv, workdir = venv_dir(), base / "elsewhere"
    workdir.mkdir()
    try:
        t0 = time.monotonic()
        checked(run([sys.executable, "-m", "venv", venv], base, user_env(), timeout=120), "python -m venv")
        # --no-compile: byte-compiling ~20 000 files of the dependencies would double pip's CPU time here
        pip = [venv / "bin" / "python", "-m", "pip", "install", "-q", "--no-compile", f"{wheel}[ros]"]
        checked(run(pip, base, user_env(venv / "bin"), timeout=900), "pip install mission[ros]")
        print(f"fresh venv in {venv} with {wheel.name}[ros] in {time.monotonic() - t0:.0f} s")
        yield Installed(venv, workdir)
    finally:
        shutil.rmtree(venv, ignore_errors=True)


SHM = Path("/dev/shm")
VENV_PREFIX = "mission-wheel-test-"


def venv_dir() -> Path:
    """A new empty folder for the ~1 GB venv: in memory (/dev/shm) when it is a roomy tmpfs, else the tests'
    tmp. On this machine's disk, writing and then deleting 20 000 files took 15–50 s more than in memory.
    Folders left by runs that were killed (their pid is gone) are removed first."""
    if SHM.is_dir() and os.access(SHM, os.W_OK) and shutil.disk_usage(SHM).free > 4 * 2**30:
        for stale in SHM.glob(f"{VENV_PREFIX}*"):
            pid = stale.name[len(VENV_PREFIX) :].split("-")[0]
            if pid.isdigit() and not Path(f"/proc/{pid}").exists():
                shutil.rmtree(stale, ignore_errors=True)
        return outside_checkout(Path(tempfile.mkdtemp(prefix=f"{VENV_PREFIX}{os.getpid()}-", dir=SHM)))
    return outside_checkout(Path(tempfile.mkdtemp(prefix=VENV_PREFIX)))


PROBE = """
import importlib, json, sys, sysconfig
import mission, mission.trees, mission.sim, mission.ros.dds as dds
failed = {}
for name in %r:
    try:
        importlib.import_module(name)
        failed[name] = None
    except ModuleNotFoundError as err:
        failed[name] = err.name
print(json.dumps({"site": sysconfig.get_paths()["purelib"], "mission": mission.__file__,
                  "trees": mission.trees.__file__, "sim": mission.sim.__file__,
                  "profile": str(dds.shm_profile_path()), "imports": failed}))
"""


@pytest.fixture(scope="module")
def probe(installed) -> dict:
    proc = checked(installed.python(PROBE % (NOT_INSTALLED,)), "the import probe")
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.wheel
def test_the_installed_package_is_the_venv_copy_and_the_folder_names_do_not_import(installed, probe):
    site = Path(probe["site"])
    assert site.is_relative_to(installed.venv)
    for key in ("mission", "trees", "sim", "profile"):
        assert Path(probe[key]).is_relative_to(site / "mission"), f"{key}: {probe[key]} is not the installed copy"
    assert Path(probe["profile"]).is_file()
    assert probe["imports"] == {name: name for name in NOT_INSTALLED}, "each fails with ModuleNotFoundError"
    assert not [name for name in NOT_INSTALLED if (site / name).exists() or (site / f"{name}.py").exists()]


@pytest.mark.wheel
def test_mission_plugins_lists_the_entry_points(installed):
    proc = checked(installed.mission("plugins"), "mission plugins")
    listed = {line.split()[0] for line in proc.stdout.splitlines() if line.strip()}
    assert set(PYPROJECT["project"]["entry-points"]["mission.perception_plugins"]) <= listed, proc.stdout
    assert set(PYPROJECT["project"]["entry-points"]["mission.vlm_clients"]) <= listed, proc.stdout
    assert "BROKEN" not in proc.stdout


@pytest.mark.wheel
def test_mission_bench_without_a_checkout_says_it_needs_one(installed):
    """bench/ is a development tool of the checkout: the installed package neither ships nor reaches for it."""
    proc = installed.mission("bench", "--quick")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        "mission: error: `mission bench` runs the benchmarks of a source checkout (bench/ is not installed); "
        "install one editable (`pip install -e .` in a clone) and run it there"
    ]


@pytest.mark.wheel
def test_a_10_s_mission_run_exits_as_a_mission_run_does(installed):
    proc = installed.mission(
        "run", "--scenario", SCENARIO, "--max-duration", "10", "--report", "report", "--quiet", timeout=180
    )
    assert proc.returncode in (0, 1), f"exit {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    report = json.loads((installed.workdir / "report" / "report.json").read_text())
    assert report["scenario"] == SCENARIO and report["success"] == (proc.returncode == 0)
    assert 0 < report["sim_time_s"] <= 10.0 + 1e-6 and report["ticks"] > 0
    verdict = "SUCCESS" if proc.returncode == 0 else "FAILURE"
    assert proc.stdout.strip().splitlines()[-1].startswith(f"{verdict}: {SCENARIO} seed 0:"), proc.stdout
    assert "Traceback" not in proc.stderr


def _loopback(address: str) -> bool:
    ip = ipaddress.ip_address(address.rsplit(":", 1)[0].strip("[]"))
    mapped = getattr(ip, "ipv4_mapped", None)
    return (mapped or ip).is_loopback


def test_the_socket_check_tells_loopback_from_every_interface():
    """The check the node is held to sees a socket bound to all interfaces (nothing is sent on either)."""
    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as lo,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as any_,
    ):
        lo.bind(("127.0.0.1", 0))
        any_.bind(("0.0.0.0", 0))
        mine = {addr: _loopback(addr) for proto, addr in inet_sockets(os.getpid()) if proto == "udp"}
        assert mine[f"127.0.0.1:{lo.getsockname()[1]}"] is True
        assert mine[f"0.0.0.0:{any_.getsockname()[1]}"] is False
    assert _loopback("[::1]:7400") and _loopback("[::ffff:127.0.0.1]:7400") and not _loopback("[::]:7400")


def _shm_files(pid: int) -> set[str]:
    out = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        with contextlib.suppress(OSError):
            target = os.readlink(fd)
            if target.startswith("/dev/shm/"):
                out.add(target)
    return out


@pytest.mark.wheel
@pytest.mark.ros
def test_mission_tree_runs_on_the_shipped_shared_memory_profile_and_stops_on_sigint(installed, probe, tmp_path):
    profile = Path(probe["profile"])
    # The gate before any DDS participant exists: the profile the node will choose is in this venv. Without
    # it FastDDS would fall back to UDP on every interface.
    assert profile.is_file() and profile.is_relative_to(installed.venv)
    env = {
        **installed.env,
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "ROS_DOMAIN_ID": str(DOMAIN_ID),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
    }
    assert "FASTRTPS_DEFAULT_PROFILES_FILE" not in env, "the node must pick the profile itself"
    node = NodeProcess(
        [str(installed.bin / "mission"), "tree", "--tree", "none"], env, tmp_path / "node.log", cwd=installed.workdir
    )
    try:
        wait_for(lambda: not node.alive() or "mission_tree: perception only" in node.log(), 60, "the node to start")
        assert node.alive(), f"the node exited {node.proc.returncode}:\n{node.log()}"
        log = node.log()
        note = re.search(r"DDS: shared memory only \((?P<path>[^)]+)\)", log)
        assert note, f"no DDS note naming the profile:\n{log}"
        assert Path(note["path"]).resolve() == profile.resolve(), f"the node chose {note['path']}, not {profile}"
        assert "mission_tree: perception only at" in log, log  # no stand-in tree file: no tree at all
        wait_for(lambda: _shm_files(node.pid), 10, "the node to map its shared-memory segments")
        for _ in range(5):  # participants open their transports at start; sample over a second to be sure
            sockets = inet_sockets(node.pid)
            beyond = [(proto, addr) for proto, addr in sockets if not _loopback(addr)]
            assert not beyond, f"sockets beyond loopback: {beyond} (all inet sockets: {sockets})"
            time.sleep(0.2)
        segments = {f for f in _shm_files(node.pid) if "_port" not in f}  # its own: port files are per domain
        node.interrupt()
        rc = node.proc.wait(timeout=20)
        assert rc == 0, f"exit {rc} after SIGINT:\n{node.log()}"
        assert "Traceback" not in node.log()
        assert not [f for f in segments if Path(f).exists()], "a clean exit releases its shared-memory segments"
    finally:
        node.stop()
