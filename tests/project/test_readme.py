"""The README is a user's reference: its generated tables match the code, and it names every verb and topic."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from mission.cli import VERBS
from tools.readme_tables import BLOCKS, README


def test_the_readme_opens_with_the_two_set_up_commands_and_they_exist():
    text = README.read_text()
    first_block = text.split("```bash\n", 1)[1].split("```", 1)[0].splitlines()
    assert [line.split()[0] for line in first_block] == ["scripts/demo", "scripts/test"]
    root = README.parent
    ci = (root / ".ci" / "run").read_text()
    assert "exec scripts/test" in ci
    for script in ("scripts/demo", "scripts/test"):
        assert (root / script).stat().st_mode & 0o111, f"{script} is not executable"


def test_every_reference_table_is_in_the_readme_and_up_to_date():
    text = README.read_text()
    for name in BLOCKS:
        assert f"<!-- reference:{name} -->" in text, f"README has no generated {name} table"
    proc = subprocess.run([sys.executable, "-m", "tools.readme_tables", "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_every_cli_verb_and_every_published_topic_is_documented():
    text = README.read_text()
    for verb in VERBS:
        assert f"`mission {verb}`" in text
    ros = Path(__file__).resolve().parents[2] / "mission" / "ros"
    node_source = "".join((ros / name).read_text() for name in ("node.py", "outputs.py"))
    for topic in (
        "/marker_detected",
        "/aruco/debug",
        "/detected_aruco_pose",
        "/aruco_poses",
        "/mission/tree",
        "/mission/redetect",
        "/tf",
    ):
        assert f'"{topic}"' in node_source, f"{topic} is no longer in the node"
        assert f"`{topic}`" in text, f"{topic} is not in the README's topic table"


def test_the_layout_table_names_every_package_folder_and_no_other():
    """The README's floor table matches the folders: each installed package's top folder, under its installed
    name, and the development folders; a folder added, moved or renamed fails here until the table says so."""
    import re

    from tools.import_contracts import mapped_roots, package_folders

    text = README.read_text(encoding="utf-8")
    table = text[text.index("| floor | folder | installed as |") :].split("\n\n", 1)[0]
    cited = set(re.findall(r"`((?:[a-z_]+/)+)`", table))
    top = {name for name in package_folders() if name.count(".") == 1}  # mission.core, mission.viz, …
    root = Path(README).parent
    expected = {
        str(folder.relative_to(root)) + "/"
        for name in top
        for folder in [mapped_roots().get(name) or root / "mission" / name.split(".")[1]]
        if (folder / "__init__.py").is_file()
    }
    expected |= {"bench/", "tools/", "tests/"}
    assert cited == expected
