"""The repo cites no document outside itself: every ``*.md`` a source, test or doc names is a file in the checkout."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: a ``*.md`` path in prose (a quoted one is a file the code writes, such as a report's name)
CITED = re.compile(r"(?<![\w/.\"'-])((?:[\w.-]+/)*[\w-]+\.md)\b")


def tracked(suffixes: tuple[str, ...]) -> list[Path]:
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return [ROOT / line for line in out.splitlines() if line.endswith(suffixes)]


def test_every_markdown_file_the_repo_names_is_in_the_repo():
    documents = {p.relative_to(ROOT).as_posix() for p in tracked((".md",))}
    names = {Path(d).name for d in documents}
    missing = []
    for path in tracked((".py", ".md", ".toml", ".cfg", ".xml", ".yaml")):
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
            for cited in CITED.findall(line):
                if cited not in documents and Path(cited).name not in names:
                    missing.append(f"{path.relative_to(ROOT)}:{number}: {cited}")
    assert not missing, "documents cited but not in the repo:\n" + "\n".join(missing)
