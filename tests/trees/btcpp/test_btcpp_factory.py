"""BehaviorTree.CPP 4.10 tests/gtest_factory.cpp, translated (XML verbatim; see btcpp_harness.py).

The files of BT.CPP's tests/trees/ that the CreateTreeFromFile… TESTs load are carried here as text
(:data:`TREE_FILES`, verbatim) and written under ``tmp_path`` with the same layout, so their ``<include>``
paths resolve as they do in BT.CPP's tests.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import pytest

from mission.trees import scopes
from mission.trees.execution import TreeRuntime
from mission.trees.loader import load_tree, read_document
from tests.trees.btcpp.btcpp_harness import TEST, Harness, Tree, port

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "BehaviorTreeFactory.XMLParsingOrder": (
        "tests XMLParser::registeredBehaviorTrees(), the C++ parser's sorted list of the tree IDs it read; "
        "no tree is created or ticked"
    ),
    "BehaviorTreeFactory.ManifestMethod": (
        "tests a C++ node class's static metadata() in factory.manifests() and writeTreeNodesModelXML's "
        "<MetadataFields>; no tree XML"
    ),
    "BehaviorTreeFactory.ReturnByValue": (
        "tests that the C++ BehaviorTreeFactory can be returned by value and move-assigned (issue #937); no XML"
    ),
    "BehaviorTreeFactory.addMetadataToManifest": (
        "tests factory.addMetadataToManifest() on a C++ manifest's metadata; no XML"
    ),
}


# ----------------------------------------------------------------------------- BT.CPP's XML texts
xml_text = """

<root BTCPP_format="4" >

    <BehaviorTree ID="MainTree">
        <Fallback name="root_selector">

            <Sequence name="door_open_sequence">
                <Action ID="IsDoorOpen" />
                <Action ID="PassThroughDoor" />
            </Sequence>

            <Sequence name="door_closed_sequence">
                <Decorator ID="Inverter">
                     <Action ID="IsDoorOpen" />
                </Decorator>
                <Action ID="OpenDoor" />
                <Action ID="PassThroughDoor" />
                <Action ID="CloseDoor" />
            </Sequence>

            <Action ID="PassThroughWindow" />

        </Fallback>
    </BehaviorTree>

    <!-- TreeNodesModel is used only by the Graphic interface -->
    <TreeNodesModel>
        <Action ID="IsDoorOpen" />
        <Action ID="PassThroughDoor" />
        <Action ID="CloseDoor" />
        <Action ID="OpenDoor" />
        <Action ID="PassThroughWindow" />
    </TreeNodesModel>
</root>
        """

xml_text_subtree = """

<root BTCPP_format="4" main_tree_to_execute="MainTree" >

    <BehaviorTree ID="MainTree">
        <Sequence>
            <Fallback>
                <Inverter>
                    <IsDoorClosed/>
                </Inverter>
                <SubTree ID="DoorClosedSubtree"/>
            </Fallback>
            <PassThroughDoor/>
        </Sequence>
    </BehaviorTree>

    <BehaviorTree ID="DoorClosedSubtree">
        <Fallback>
            <OpenDoor/>
            <RetryUntilSuccessful num_attempts="5">
                <PickLock/>
            </RetryUntilSuccessful>
            <SmashDoor/>
        </Fallback>
    </BehaviorTree>

</root>  """

xml_ports_subtree = """

<root BTCPP_format="4" main_tree_to_execute="MainTree">

  <BehaviorTree ID="TalkToMe">
    <Sequence>
      <SaySomething message="{hello_msg}" />
      <SaySomething message="{bye_msg}" />
      <Script code=" output:='done!' " />
    </Sequence>
  </BehaviorTree>

  <BehaviorTree ID="MainTree">
    <Sequence>
      <Script code = " talk_hello:='hello' " />
      <Script code = " talk_bye:='bye bye' " />
      <SubTree ID="TalkToMe" hello_msg="{talk_hello}"
                             bye_msg="{talk_bye}"
                             output="{talk_out}" />
      <SaySomething message="{talk_out}" />
    </Sequence>
  </BehaviorTree>

</root> """

#: BT.CPP's tests/trees/ (relative path → text, verbatim)
TREE_FILES: dict[str, str] = {
    "trees/child/child/child_child_no_include.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ChildChildNoInclude">
  <BehaviorTree ID="ChildChildNoInclude">
    <AlwaysSuccess />
  </BehaviorTree>
</root>
""",
    "trees/child/child_include_child.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ChildIncludeChild">
  <include path="child/child_child_no_include.xml" />

  <BehaviorTree ID="ChildIncludeChild">
    <Sequence>
      <SubTree ID="ChildChildNoInclude" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/child/child_include_parent.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ChildIncludeParent">
  <include path="../parent_no_include.xml" />

  <BehaviorTree ID="ChildIncludeParent">
    <Sequence>
      <SubTree ID="ParentNoInclude" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/child/child_include_sibling.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ChildIncludeSibling">
  <include path="child_no_include.xml" />

  <BehaviorTree ID="ChildIncludeSibling">
    <Sequence>
      <SubTree ID="ChildNoInclude" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/child/child_no_include.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ChildNoInclude">
  <BehaviorTree ID="ChildNoInclude">
    <AlwaysSuccess />
  </BehaviorTree>
</root>
""",
    "trees/parent_include_child.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ParentIncludeChild">
  <include path="child/child_no_include.xml" />

  <BehaviorTree ID="ParentIncludeChild">
    <Sequence>
      <SubTree ID="ChildNoInclude" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/parent_include_child_include_child.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ParentIncludeChildIncludeChild">
  <include path="child/child_include_child.xml" />

  <BehaviorTree ID="ParentIncludeChildIncludeChild">
    <Sequence>
      <SubTree ID="ChildIncludeChild" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/parent_include_child_include_parent.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ParentIncludeChildIncludeParent">
  <include path="child/child_include_parent.xml" />

  <BehaviorTree ID="ParentIncludeChildIncludeParent">
    <Sequence>
      <SubTree ID="ChildIncludeParent" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/parent_include_child_include_sibling.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ParentIncludeChildIncludeSibling">
  <include path="child/child_include_sibling.xml" />

  <BehaviorTree ID="ParentIncludeChildIncludeSibling">
    <Sequence>
      <SubTree ID="ChildIncludeSibling" />
      <AlwaysSuccess />
    </Sequence>
  </BehaviorTree>
</root>
""",
    "trees/parent_no_include.xml": """\
<root BTCPP_format="4" main_tree_to_execute = "ParentNoInclude">
  <BehaviorTree ID="ParentNoInclude">
    <AlwaysSuccess />
  </BehaviorTree>
</root>
""",
}


# ----------------------------------------------------------------------------- helpers
def file_path(bt: Harness, relative_path: str) -> Path:
    """BT.CPP's FilePath(relative): its tests folder, here BT.CPP's tests/trees/ written under tmp_path."""
    for rel, text in TREE_FILES.items():
        target = bt.tmp_path / "tests" / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text)
    return bt.tmp_path / "tests" / relative_path


def create_tree_from_file(bt: Harness, path: Path) -> Tree:
    """``factory.createTreeFromFile(path)``."""
    runtime = TreeRuntime()
    return Tree(load_tree(path, bt.factory, runtime), runtime)


def register_tree_text_again(bt: Harness, xml: str) -> None:
    """``registerBehaviorTreeFromText`` of a text whose trees replace the ones registered before (BT.CPP's
    registry keeps the last tree of each ID; the harness includes every text, which would define them twice)."""
    bt.texts.clear()
    bt.register_tree_text(xml)


def subtree_nodes(tree: Tree) -> list[list[tuple[str, bool]]]:
    """``tree.subtrees[i]->nodes`` as (name, is a SubTree node), in creation order: each XML node's BT.CPP
    state is a layer of its behaviour's runtime (a SubTree is flattened onto its tree's root), run in the
    blackboard scope of the tree it belongs to."""
    found: dict[int, list[tuple[str, bool]]] = {}

    def visit(node) -> None:
        layers = node.bt.layers
        for i, layer in enumerate(layers):
            found.setdefault(id(layer.conditions.env.scope), []).append((layer.name, i < len(layers) - 1))
        for child in node.children:
            visit(child)

    visit(tree.root)
    return list(found.values())


def subtree_scopes(tree: Tree) -> list[scopes.Scope]:
    """``tree.subtrees[i]->blackboard`` (as blackboard scopes), in creation order."""
    found: dict[int, scopes.Scope] = {}

    def visit(node) -> None:
        for layer in node.bt.layers:
            found.setdefault(id(layer.conditions.env.scope), layer.conditions.env.scope)
        for child in node.children:
            visit(child)

    visit(tree.root)
    return list(found.values())


def register_cross_door(bt: Harness) -> None:
    """sample_nodes' CrossDoor::registerNodes (IsDoorClosed and SmashDoor are conditions); the TESTs that use
    it create trees without ticking them, so the door's state and its sleeps are left out."""
    for tag in ("PassThroughDoor", "OpenDoor", "PickLock"):
        bt.register_simple_action(tag, lambda _node: "SUCCESS")
    for tag in ("IsDoorClosed", "SmashDoor"):
        bt.register_simple_condition(tag, lambda _node: "SUCCESS")


def register_say_something(bt: Harness) -> None:
    """DummyNodes::SaySomething: prints its input ``message`` (BT.CPP throws when it cannot be read)."""
    bt.register_simple_action("SaySomething", lambda _node: "SUCCESS", [("message", str, port(doc="the text"))])


@pytest.fixture
def bt(tmp_path):
    """Each TEST makes its own ``BehaviorTreeFactory factory;``."""
    return Harness(tmp_path)


# ----------------------------------------------------------------------------- the TESTs
@TEST("BehaviorTreeFactory.NotRegisteredNode")
def test_not_registered_node(bt):
    # BT.CPP throws from createTreeFromText (IsDoorOpen … are not registered), twice
    bt.raises_by_first_tick(xml_text)
    bt.raises_by_first_tick(xml_text)  # std::make_shared<BT::Tree>(factory.createTreeFromText(xml_text))


@TEST("BehaviorTreeFactory.Subtree")
def test_subtree(bt):
    register_cross_door(bt)
    tree = bt.load(xml_text_subtree)

    subtrees = subtree_nodes(tree)
    assert len(subtrees) == 2

    main_tree = subtrees[0]
    subtree = subtrees[1]

    assert len(main_tree) == 6
    assert main_tree[0][0] == "Sequence"
    assert main_tree[1][0] == "Fallback"
    assert main_tree[2][0] == "Inverter"
    assert main_tree[3][0] == "IsDoorClosed"
    assert main_tree[4][1]  # NodeType::SUBTREE
    assert main_tree[5][0] == "PassThroughDoor"

    assert len(subtree) == 5
    assert subtree[0][0] == "Fallback"
    assert subtree[1][0] == "OpenDoor"
    assert subtree[2][0] == "RetryUntilSuccessful"
    assert subtree[3][0] == "PickLock"
    assert subtree[4][0] == "SmashDoor"


@TEST("BehaviorTreeFactory.Issue7")
def test_issue7(bt):
    xml_text_issue = """
<root BTCPP_format="4">
    <BehaviorTree ID="ReceiveGuest">
    </BehaviorTree>
</root> """
    # BT.CPP throws from XMLParser::loadFromText (a BehaviorTree without a root node)
    bt.raises_by_first_tick(xml_text_issue)


@TEST("BehaviorTreeFactory.SubTreeWithRemapping")
def test_sub_tree_with_remapping(bt):
    register_say_something(bt)
    tree = bt.load(xml_ports_subtree)

    main_bb, talk_bb = subtree_scopes(tree)[0], subtree_scopes(tree)[1]

    def get(scope, key):
        return scopes.read(scope.entry_path(key))

    # Should not throw
    tree.tick_while_running()

    # entryInfo(key)->type() == typeid(std::string): the entries hold text
    assert type(get(main_bb, "talk_hello")) is str
    assert type(get(main_bb, "talk_bye")) is str
    assert type(get(main_bb, "talk_out")) is str

    assert type(get(talk_bb, "bye_msg")) is str
    assert type(get(talk_bb, "hello_msg")) is str
    assert type(get(talk_bb, "output")) is str

    assert get(main_bb, "talk_hello") == "hello"
    assert get(main_bb, "talk_bye") == "bye bye"
    assert get(main_bb, "talk_out") == "done!"

    # these ports should not be present in the subtree TalkToMe
    assert not scopes.exists(talk_bb.entry_path("talk_hello"))
    assert not scopes.exists(talk_bb.entry_path("talk_bye"))
    assert not scopes.exists(talk_bb.entry_path("talk_out"))


@TEST("BehaviorTreeFactory.CreateTreeFromFile")
def test_create_tree_from_file(bt):
    # should not throw
    path = file_path(bt, "trees/parent_no_include.xml")
    tree = create_tree_from_file(bt, path)
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.CreateTreeFromFileWhichIncludesFileFromSameDirectory")
def test_create_tree_from_file_which_includes_file_from_same_directory(bt):
    # should not throw
    path = file_path(bt, "trees/child/child_include_sibling.xml")
    tree = create_tree_from_file(bt, path)
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.CreateTreeFromFileWhichIncludesFileFromChildDirectory")
def test_create_tree_from_file_which_includes_file_from_child_directory(bt):
    # should not throw
    path = file_path(bt, "trees/parent_include_child.xml")
    tree = create_tree_from_file(bt, path)
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.CreateTreeFromFileWhichIncludesFileFromChildDirectoryWhichIncludesFileFromSameDirectory")
def test_create_tree_from_file_which_includes_file_from_child_directory_which_includes_file_from_same_directory(
    bt,
):
    # should not throw
    path = file_path(bt, "trees/parent_include_child_include_sibling.xml")
    tree = create_tree_from_file(bt, path)
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.CreateTreeFromFileWhichIncludesFileFromChildDirectoryWhichIncludesFileFromChildDirectory")
def test_create_tree_from_file_which_includes_file_from_child_directory_which_includes_file_from_child_directory(
    bt,
):
    # should not throw
    path = file_path(bt, "trees/parent_include_child_include_child.xml")
    tree = create_tree_from_file(bt, path)
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.CreateTreeFromFileWhichIncludesFileFromChildDirectoryWhichIncludesFileFromParentDirectory")
def test_create_tree_from_file_which_includes_file_from_child_directory_which_includes_file_from_parent_directory(
    bt,
):
    # should not throw
    path = file_path(bt, "trees/parent_include_child_include_parent.xml")
    tree = create_tree_from_file(bt, path)
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.WrongTreeName")
def test_wrong_tree_name(bt):
    xml_a = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="MainTree">
      <AlwaysSuccess/>
    </BehaviorTree>
  </root> """
    bt.register_tree_text(xml_a)
    # BT.CPP throws from createTree("Wrong Name")
    bt.raises_by_first_tick(main_tree="Wrong Name")


@TEST("BehaviorTreeReload.ReloadSameTree")
def test_reload_same_tree(bt):
    xml_a = """
<root BTCPP_format="4" >
  <BehaviorTree ID="MainTree">
    <AlwaysSuccess/>
  </BehaviorTree>
</root> """

    xml_b = """
<root BTCPP_format="4" >
  <BehaviorTree ID="MainTree">
    <AlwaysFailure/>
  </BehaviorTree>
</root> """

    bt.register_tree_text(xml_a)
    tree = bt.load(main_tree="MainTree")
    assert tree.tick_while_running() == "SUCCESS"

    register_tree_text_again(bt, xml_b)
    tree = bt.load(main_tree="MainTree")
    assert tree.tick_while_running() == "FAILURE"


@TEST("BehaviorTreeFactory.FactoryDestroyedBeforeTick")
@pytest.mark.xfail(
    strict=True,
    reason="an input port declared without a default that the XML does not set is a load error here "
    "(trees/loader.py _Compiler.node: missing required port; docs/btcpp.md 'Differences'); BT.CPP's getInput only "
    "fails when the node reads it, and ActionIssue1046 ignores that",
)
def test_factory_destroyed_before_tick(bt):
    # The XML deliberately does NOT set the "value" port so
    # that getInput falls through to the manifest to read
    # the port info.
    xml_text_issue_1046 = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="Main">
      <ActionIssue1046/>
    </BehaviorTree>
  </root> """

    def tick(node) -> str:
        # getInput("value", value): expected to fail (no default, not in XML), but must not crash; the result
        # is ignored
        with contextlib.suppress(Exception):
            node.input("value")
        return "SUCCESS"

    def create() -> Tree:
        factory = Harness(bt.tmp_path)  # factory created in an inner scope, gone when this returns
        factory.register_simple_action("ActionIssue1046", tick, [("value", int, port(doc="a test port"))])
        factory.register_tree_text(xml_text_issue_1046)
        return factory.load(main_tree="Main")

    tree = create()
    # (BT.CPP then checks every node's manifest pointer points into the tree's own copy: C++ memory only)
    # Ticking after factory destruction should not crash.
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.CreateTreeFromTextFindsRegisteredSubtree")
def test_create_tree_from_text_finds_registered_subtree(bt):
    # Step 1: register a subtree definition
    subtree_xml = """
  <root BTCPP_format="4">
    <BehaviorTree ID="MyTree">
      <AlwaysSuccess/>
    </BehaviorTree>
  </root>"""
    bt.register_tree_text(subtree_xml)

    # Verify "MyTree" is registered (factory.registeredBehaviorTrees(): the trees of the registered texts)
    assert sum(len(read_document(path).trees) for path in bt.texts) == 1

    # Step 2: use createTreeFromText with XML that references the
    # registered subtree via <SubTree ID="MyTree"/>
    main_xml = """
  <root BTCPP_format="4">
    <BehaviorTree ID="TestTree">
      <SubTree ID="MyTree"/>
    </BehaviorTree>
  </root>"""

    # createTreeFromText(text) registers the text's trees beside the registered ones, then creates the text's
    # tree; the harness's load(text) reads the text alone, so it is registered and created by its ID
    bt.register_tree_text(main_xml)
    tree = bt.load(main_tree="TestTree")
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BehaviorTreeFactory.MalformedXML_InvalidRoot")
def test_malformed_xml_invalid_root(bt):
    # XML that is not valid XML at all; BT.CPP throws from createTreeFromText
    bt.raises_by_first_tick("<not valid xml!!!")


@TEST("BehaviorTreeFactory.MalformedXML_MissingRootElement")
def test_malformed_xml_missing_root_element(bt):
    # Well-formed XML but missing <root> element
    xml = """
  <something BTCPP_format="4">
    <BehaviorTree ID="Main">
      <AlwaysSuccess/>
    </BehaviorTree>
  </something>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("BehaviorTreeFactory.MalformedXML_EmptyBehaviorTree")
def test_malformed_xml_empty_behavior_tree(bt):
    # BehaviorTree element with no children
    xml = """
  <root BTCPP_format="4">
    <BehaviorTree ID="Main">
    </BehaviorTree>
  </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("BehaviorTreeFactory.MalformedXML_EmptyBehaviorTreeID")
def test_malformed_xml_empty_behavior_tree_id(bt):
    # BehaviorTree element with empty ID when multiple trees exist
    xml = """
  <root BTCPP_format="4">
    <BehaviorTree ID="">
      <AlwaysSuccess/>
    </BehaviorTree>
    <BehaviorTree ID="Other">
      <AlwaysSuccess/>
    </BehaviorTree>
  </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("BehaviorTreeFactory.MalformedXML_MissingBehaviorTreeID")
def test_malformed_xml_missing_behavior_tree_id(bt):
    # Multiple BehaviorTree elements without IDs
    xml = """
  <root BTCPP_format="4">
    <BehaviorTree>
      <AlwaysSuccess/>
    </BehaviorTree>
    <BehaviorTree>
      <AlwaysFailure/>
    </BehaviorTree>
  </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


def _nested(depth: int) -> str:
    """The TEST's XML, built as it builds it."""
    xml = """<root BTCPP_format="4"><BehaviorTree ID="Main">"""
    xml += "<Sequence>" * depth
    xml += "<AlwaysSuccess/>"
    xml += "</Sequence>" * depth
    xml += "</BehaviorTree></root>"
    return xml


@TEST("BehaviorTreeFactory.MalformedXML_DeeplyNestedElements")
def test_malformed_xml_deeply_nested_elements(bt):
    # Generate XML with nesting depth that exceeds the limit (256).
    # This should throw a readable exception rather than crash with
    # a stack overflow.
    xml = _nested(300)
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("BehaviorTreeFactory.MalformedXML_ModerateNestingIsOK")
def test_malformed_xml_moderate_nesting_is_ok(bt):
    # Nesting depth well within the limit should succeed.
    xml = _nested(50)
    # Should not throw
    bt.load(xml)


@TEST("BehaviorTreeFactory.MalformedXML_MultipleBTChildElements")
def test_malformed_xml_multiple_bt_child_elements(bt):
    # BehaviorTree with more than one child element
    xml = """
  <root BTCPP_format="4">
    <BehaviorTree ID="Main">
      <AlwaysSuccess/>
      <AlwaysFailure/>
    </BehaviorTree>
  </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("BehaviorTreeFactory.MalformedXML_CompletelyEmpty")
def test_malformed_xml_completely_empty(bt):
    # Completely empty string; BT.CPP throws from createTreeFromText
    bt.raises_by_first_tick("")


@TEST("BehaviorTreeFactory.MalformedXML_EmptyRoot")
def test_malformed_xml_empty_root(bt):
    # Root element with no children at all
    xml = """<root BTCPP_format="4"></root>"""
    # No BehaviorTree elements: registering succeeds but creating
    # a tree should fail because there is nothing to instantiate.
    bt.register_tree_text(xml)
    bt.raises_by_first_tick(main_tree="MainTree")


@TEST("BehaviorTreeFactory.MalformedXML_UnknownNodeType")
def test_malformed_xml_unknown_node_type(bt):
    # Reference to a node type that is not registered
    xml = """
  <root BTCPP_format="4">
    <BehaviorTree ID="Main">
      <NonExistentNodeType/>
    </BehaviorTree>
  </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)
