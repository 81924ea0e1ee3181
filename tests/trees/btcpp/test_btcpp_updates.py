"""BehaviorTree.CPP 4.10 tests/gtest_updates.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}

xml_text_check = """

  <root BTCPP_format="4" >
    <BehaviorTree ID="Check">
      <Sequence>

        <Fallback>
          <WasEntryUpdated entry="A"/>
          <TestA/>
        </Fallback>

        <SkipUnlessUpdated entry="A">
          <TestB/>
        </SkipUnlessUpdated>

      </Sequence>
    </BehaviorTree>
  </root>"""


@TEST("EntryUpdates.NoEntry")
def test_no_entry(tmp_path):
    bt = Harness(tmp_path)
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
    <root BTCPP_format="4" >
      <BehaviorTree ID="Main">
        <Sequence>
          <SubTree ID="Check" _autoremap="true"/>
        </Sequence>
      </BehaviorTree>
    </root>"""

    bt.register_tree_text(xml_text_check)
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="Main")
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 1  # fallback!
    assert counters[1] == 0  # skipped


@TEST("EntryUpdates.Initialized")
def test_initialized(tmp_path):
    bt = Harness(tmp_path)
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
    <root BTCPP_format="4" >
      <BehaviorTree ID="Main">
        <Sequence>
          <Script code="A:=1;B:=1"/>
          <SubTree ID="Check" _autoremap="true"/>
        </Sequence>
      </BehaviorTree>
    </root>"""

    bt.register_tree_text(xml_text_check)
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="Main")
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 0  # fallback!
    assert counters[1] == 1  # skipped


@TEST("EntryUpdates.UpdateOnce")
def test_update_once(tmp_path):
    bt = Harness(tmp_path)
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
    <root BTCPP_format="4" >
      <BehaviorTree ID="Main">
        <Sequence>
          <Script code="A:=1"/>
          <Repeat num_cycles="2" >
            <SubTree ID="Check" _autoremap="true"/>
          </Repeat>
        </Sequence>
      </BehaviorTree>
    </root>"""

    bt.register_tree_text(xml_text_check)
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="Main")
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 1  # fallback!
    assert counters[1] == 1  # skipped


@TEST("EntryUpdates.UpdateTwice")
def test_update_twice(tmp_path):
    bt = Harness(tmp_path)
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
    <root BTCPP_format="4" >
      <BehaviorTree ID="Main">
        <Repeat num_cycles="2" >
          <Sequence>
            <Script code="A:=1"/>
            <SubTree ID="Check" _autoremap="true"/>
          </Sequence>
        </Repeat>
      </BehaviorTree>
    </root>"""

    bt.register_tree_text(xml_text_check)
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="Main")
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 0  # fallback!
    assert counters[1] == 2  # skipped
