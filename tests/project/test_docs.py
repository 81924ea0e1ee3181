"""The documentation is a user's reference: a site that builds strictly, examples that run, tables generated
from the code, every verb and topic named, and a README that is a front page."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from mission.cli import VERBS, build_parser
from tools.reference_tables import BLOCKS, DOCS, README, ROOT, pages

SHARED_DATA = ROOT.parent / "shared" / "data"  # the real photos, beside the checkout as CI has them
EXAMPLE = re.compile(
    r"<!-- example(?:: file (?P<file>[\w./-]+))? -->\n```(?P<lang>\w+)[^\n]*\n(?P<body>.*?)^```", re.S | re.M
)
FENCE = re.compile(r"^```(?P<lang>\w*)[^\n]*\n(?P<body>.*?)^```", re.S | re.M)


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


# -- the front page ----------------------------------------------------------------------------------------


def test_the_readme_opens_with_the_two_set_up_commands_and_they_exist():
    text = _text(README)
    first_block = text.split("```bash\n", 1)[1].split("```", 1)[0].splitlines()
    assert [line.split()[0] for line in first_block] == ["scripts/demo", "scripts/test"]
    ci = (ROOT / ".ci" / "run").read_text()
    assert "exec scripts/test" in ci
    for script in ("scripts/demo", "scripts/test"):
        assert (ROOT / script).stat().st_mode & 0o111, f"{script} is not executable"


def test_the_readme_is_a_front_page_that_points_into_the_docs():
    text = _text(README)
    assert len(text.splitlines()) <= 250
    linked = set(re.findall(r"\]\((docs/[\w/.-]+\.md)\)", text))
    assert {"docs/quickstart.md", "docs/reference/cli.md", "docs/reference/config.md", "docs/ros.md"} <= linked
    for link in linked:
        assert (ROOT / link).is_file(), f"README links {link}, which does not exist"


# -- the site ----------------------------------------------------------------------------------------------


def test_the_site_builds_strictly_with_every_internal_link_and_anchor_resolved(tmp_path):
    """mkdocs.yml sets strict and warns on every unresolved link and anchor, so any one fails the build. Links
    to the web are not followed: nothing here may leave loopback."""
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (tmp_path / "site" / "reference" / "config" / "index.html").is_file()


def test_every_page_is_in_the_sites_navigation_and_the_results_page_shows_benchmarks_md():
    import yaml

    site = yaml.safe_load(_text(ROOT / "mkdocs.yml"))
    nav = _text(ROOT / "mkdocs.yml")
    excluded = set(site.get("exclude_docs", "").split())  # templates, not pages (docs/bench/notes.md)
    for page in sorted(DOCS.rglob("*.md")):
        name = page.relative_to(DOCS).as_posix()
        assert name in excluded or f": {name}" in nav, f"{page} is not in mkdocs.yml's nav"
    from tools.mkdocs_hooks import on_page_markdown

    shown = on_page_markdown(_text(DOCS / "bench" / "results.md"), page=None)
    assert "\n## robustness\n" in shown and "\n## perception\n" in shown  # the benchmarks' own sections
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", shown)
    assert pictures and all((DOCS / "bench" / p).is_file() for p in pictures), pictures


# -- generated and required content --------------------------------------------------------------------


def test_every_reference_table_is_in_the_docs_and_up_to_date():
    text = "".join(_text(p) for p in pages())
    for name in BLOCKS:
        assert text.count(f"<!-- reference:{name} -->") == 1, f"the docs need exactly one generated {name} table"
    proc = subprocess.run(
        [sys.executable, "-m", "tools.reference_tables", "--check"], capture_output=True, text=True, cwd=ROOT
    )
    assert proc.returncode == 0, proc.stderr


def test_every_cli_verb_and_every_published_topic_is_documented():
    cli = _text(DOCS / "reference" / "cli.md")
    for verb in VERBS:
        assert f"`mission {verb}`" in cli
    ros_doc = _text(DOCS / "ros.md")
    ros = ROOT / "mission" / "ros"
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
        assert f"`{topic}`" in ros_doc, f"{topic} is not in docs/ros.md's topic table"


def test_the_layout_table_names_every_package_folder_and_no_other():
    """The floor table matches the folders: each installed package's top folder, under its installed name, and
    the development folders; a folder added, moved or renamed fails here until the table says so."""
    from tools.import_contracts import mapped_roots, package_folders

    text = _text(DOCS / "guide" / "how-it-fits.md")
    table = text[text.index("| floor | folder | installed as |") :].split("\n\n", 1)[0]
    cited = set(re.findall(r"`((?:[a-z_]+/)+)`", table))
    top = {name for name in package_folders() if name.count(".") == 1}  # mission.core, mission.viz, …
    expected = {
        str(folder.relative_to(ROOT)) + "/"
        for name in top
        for folder in [mapped_roots().get(name) or ROOT / "mission" / name.split(".")[1]]
        if (folder / "__init__.py").is_file()
    }
    expected |= {"bench/", "tools/", "tests/"}
    assert cited == expected


# -- examples ----------------------------------------------------------------------------------------------


def _commands(body: str) -> list[list[str]]:
    """The `mission …` commands of a shell block, as argument lists (continuations joined, comments, pipes
    and the shell's operators cut away, leading VAR=value assignments and `!` dropped)."""
    out = []
    for line in body.replace("\\\n", " ").splitlines():
        lexer = shlex.shlex(line, posix=True, punctuation_chars=";&|")
        lexer.whitespace_split = True
        lexer.commenters = "#"
        words: list[str] = []
        for token in [*lexer, ";"]:
            if token in (";", "&&", "||", "|", "&"):
                while words and (words[0] == "!" or re.match(r"^[A-Z_]+=", words[0])):
                    words.pop(0)
                if words[:1] == ["mission"]:
                    out.append(words[1:])
                words = []
            else:
                words.append(token)
    return out


def _shell_blocks() -> list[tuple[str, str]]:
    return [
        (f"{path.relative_to(ROOT)}", m.group("body"))
        for path in pages()
        for m in FENCE.finditer(_text(path))
        if m.group("lang") in ("bash", "sh", "shell")
    ]


def test_every_mission_command_in_the_docs_is_one_the_command_line_accepts():
    """Every `mission …` line of every shell block, examples run or not, parsed by the real parser: a verb or
    a flag renamed in the code fails here until the docs say so."""
    from bench.command import build_parser as bench_parser

    seen = 0
    for where, body in _shell_blocks():
        for args in _commands(body):
            seen += 1
            try:  # as mission/cli.py reads a command line: `bench` forwards its own; `tree` passes --ros-args on
                known, extra = build_parser().parse_known_args(args)
                if known.verb == "bench":
                    bench_parser().parse_args(args[1:])
                elif extra and not (known.verb == "tree" and "--ros-args" in extra):
                    raise SystemExit(f"unrecognized arguments: {' '.join(extra)}")
            except SystemExit as exc:
                if exc.code not in (0, None):  # --help, --version
                    pytest.fail(f"{where}: `mission {shlex.join(args)}` is refused by the command line: {exc}")
    assert seen > 50


def _examples(path: Path) -> list[re.Match[str]]:
    return list(EXAMPLE.finditer(_text(path)))


PAGES_WITH_EXAMPLES = [p for p in pages() if _examples(p)]


@pytest.mark.parametrize("page", PAGES_WITH_EXAMPLES, ids=[str(p.relative_to(ROOT)) for p in PAGES_WITH_EXAMPLES])
def test_the_examples_of_a_page_run_as_written(page: Path, tmp_path: Path):
    """A page's examples (the blocks after `<!-- example -->`) run in order, in an empty directory, with
    `mission` on the PATH as after `pip install`: shell blocks with bash -e, Python blocks with this Python,
    and a `<!-- example: file NAME -->` block written to NAME for the blocks after it."""
    text = _text(page)
    if "MISSION_SHARED_DATA" in text and not SHARED_DATA.is_dir():
        pytest.skip(f"{SHARED_DATA} (the real photos) is not beside the checkout")
    env = {
        **os.environ,
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
        "MISSION_SHARED_DATA": str(SHARED_DATA),
    }
    for m in EXAMPLE.finditer(text):
        lang, body, name = m.group("lang"), m.group("body"), m.group("file")
        line = text[: m.start()].count("\n") + 2
        if name:
            (tmp_path / name).write_text(body, encoding="utf-8")
            continue
        if lang in ("bash", "sh", "shell"):
            command = ["bash", "-euo", "pipefail", "-c", body]
        elif lang == "python":
            command = [sys.executable, "-c", body]
        else:
            pytest.fail(f"{page.name}:{line}: an example in {lang!r} cannot be run; mark it `file NAME`")
        proc = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, f"{page.relative_to(ROOT)}:{line}: the example failed\n{proc.stdout}{proc.stderr}"
