"""`mission viz TREE.xml`: every format draws every node of a shipped tree, without Graphviz."""

from __future__ import annotations

import itertools
import re
import xml.etree.ElementTree as ET

import pytest
from PIL import Image

from mission.cli import main
from mission.trees.loader import describe_tree, resolve_tree_path
from mission.viz.layout import layout_tree
from mission.viz.model import from_description

SVG = "{http://www.w3.org/2000/svg}"


def node_names(tree: str) -> list[str]:
    return [n.name for n in from_description(describe_tree(resolve_tree_path(tree))).walk()]


def svg_texts(path) -> str:
    root = ET.parse(path).getroot()
    return "\n".join("".join(t.itertext()) for t in root.iter(f"{SVG}text"))


@pytest.mark.parametrize("tree", ["mission.xml", "follow.xml", "dock.xml"])
def test_svg_parses_and_shows_every_node_with_its_ports(tree, tmp_path):
    out = tmp_path / "tree.svg"
    assert main(["viz", tree, "--format", "svg", "-o", str(out)]) == 0
    texts = svg_texts(out)
    groups = [g for g in ET.parse(out).getroot().iter(f"{SVG}g") if "node" in g.get("class", "").split()]
    assert [g.get("data-name") for g in groups] == node_names(tree)
    for name in node_names(tree):
        assert name in texts
    if tree == "follow.xml":
        assert "max_misses = 4" in texts and "timeout_s = 25.0" in texts


def test_text_formats_list_every_node_and_ascii_is_plain_ascii(capsys):
    assert main(["viz", "mission.xml"]) == 0
    unicode_out = capsys.readouterr().out
    assert main(["viz", "mission.xml", "--format", "ascii"]) == 0
    ascii_out = capsys.readouterr().out
    for name in node_names("mission.xml"):
        assert name in unicode_out and name in ascii_out
    assert "└── " in unicode_out
    assert ascii_out.isascii() and "`-- " in ascii_out
    assert "IsTargetVisible  Condition  target=target max_misses=4" in ascii_out


def test_dot_is_a_digraph_with_one_node_per_tree_node(capsys):
    assert main(["viz", "follow.xml", "--format", "dot"]) == 0
    dot = capsys.readouterr().out
    assert dot.startswith("digraph behaviour_tree {")
    assert len(re.findall(r"^  n\d+ \[label=", dot, re.M)) == len(node_names("follow.xml"))
    assert len(re.findall(r"^  n\d+ -> n\d+", dot, re.M)) == len(node_names("follow.xml")) - 1


def test_png_is_drawn_without_graphviz(tmp_path):
    out = tmp_path / "tree.png"
    assert main(["viz", "follow.xml", "-o", str(out)]) == 0  # the extension picks the format
    with Image.open(out) as img:
        assert img.format == "PNG"
        assert img.width > 600 and img.height > 300


def test_static_html_is_self_contained(tmp_path):
    out = tmp_path / "tree.html"
    assert main(["viz", "mission.xml", "--format", "html", "-o", str(out)]) == 0
    page = out.read_text()
    for name in node_names("mission.xml"):
        assert f'data-name="{name}"' in page
    # nothing is fetched from anywhere: no src/href to a URL (the SVG namespace is a name, not a fetch)
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", page)
    assert "@import" not in page and "cdn" not in page.lower()


def test_layout_is_tidy_no_overlaps_and_parents_centred_over_children():
    root = from_description(describe_tree(resolve_tree_path("mission.xml")))
    lay = layout_tree(root)
    by_row: dict[float, list] = {}
    for box in lay.boxes.values():
        by_row.setdefault(box.y, []).append(box)
    for boxes in by_row.values():
        boxes.sort(key=lambda b: b.x)
        for a, b in itertools.pairwise(boxes):
            assert a.x + a.w <= b.x, "boxes in one row overlap"
    for n in root.walk():
        if n.children:
            first, last = lay.boxes[n.children[0].id], lay.boxes[n.children[-1].id]
            assert lay.boxes[n.id].cx == pytest.approx((first.cx + last.cx) / 2)
            assert all(lay.boxes[c.id].y > lay.boxes[n.id].y for c in n.children)


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["viz", str(tmp_path / "missing.xml")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "missing.xml" in err
    assert main(["viz", "follow.xml", "--tick", "3"]) == 2
    assert "--tick needs --log" in capsys.readouterr().err
    assert main(["viz", "follow.xml", "--format", "png"]) == 2
    assert "needs -o" in capsys.readouterr().err
