"""BehaviorTree.CPP 4.10 tests/gtest_polymorphic_ports.cpp: nothing to translate.

Every TEST is about C++ class hierarchies (Animal ← Cat ← Sphynx, Animal ← Dog, tests/include/animal_hierarchy_test.h)
passed as ``std::shared_ptr`` through ``BT::Any``, the blackboard or ports, with up- and downcasts registered in a
``PolymorphicCastRegistry``. Our ports carry str, int, float, bool and Pose2D values: there is no type hierarchy to
cast along, so the XML TESTs cannot be written with our port types either.
"""

from __future__ import annotations

_ANY = "tests the C++ BT::Any::cast / tryCastWithRegistry API with a PolymorphicCastRegistry, no XML: "
_BB = "tests the C++ Blackboard::get API with a PolymorphicCastRegistry (setPolymorphicCastRegistry), no XML: "
_XML = (
    "needs C++ class-hierarchy port types (std::shared_ptr<Animal/Cat/Sphynx/Dog>) and the casts registered by "
    "RegisterAnimalHierarchy(factory): "
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "PolymorphicPortTest.AnyCast_SameType": _ANY + "an Animal::Ptr does not downcast to Cat::Ptr / Sphynx::Ptr",
    "PolymorphicPortTest.AnyCast_Upcast": _ANY + "a Cat::Ptr upcasts to Animal::Ptr, not down to Sphynx::Ptr",
    "PolymorphicPortTest.AnyCast_TransitiveUpcast": _ANY + "a Sphynx::Ptr upcasts to Cat::Ptr and Animal::Ptr",
    "PolymorphicPortTest.AnyCast_DowncastWithRuntimeTypeCheck": _ANY + "a Cat::Ptr holding a Sphynx downcasts",
    "PolymorphicPortTest.AnyCast_UnrelatedTypes": _ANY + "Cat::Ptr and Dog::Ptr do not cast to each other",
    "PolymorphicPortTest.Blackboard_UpcastAndDowncast": _BB + "a Cat read as Animal and Cat, not as Sphynx",
    "PolymorphicPortTest.Blackboard_TransitiveUpcast": _BB + "a Sphynx read as Animal, Cat and Sphynx",
    "PolymorphicPortTest.XML_ValidUpcast": _XML + "OutputPort<Cat::Ptr> read by InputPort<Cat::Ptr> and "
    "InputPort<Animal::Ptr>",
    "PolymorphicPortTest.XML_TransitiveUpcast": _XML + "OutputPort<Sphynx::Ptr> read by InputPort<Animal::Ptr>",
    "PolymorphicPortTest.XML_InoutRejectsTypeMismatch": _XML + "OutputPort<Cat::Ptr> connected to "
    "BidirectionalPort<Animal::Ptr> is refused",
    "PolymorphicPortTest.XML_InvalidConnection_UnrelatedTypes": _XML + "OutputPort<Cat::Ptr> connected to "
    "InputPort<Dog::Ptr> is refused",
    "PolymorphicPortTest.XML_DowncastSucceedsAtRuntime": _XML + "an Animal::Ptr holding a Cat read by "
    "InputPort<Cat::Ptr>",
    "PolymorphicPortTest.XML_DowncastFailsAtRuntime": _XML + "an Animal::Ptr holding an Animal read by "
    "InputPort<Cat::Ptr> fails at run time",
}
