"""Every behaviour module, imported so each leaf registers its XML tag (see behaviours/registry.py).

The catalogue of tags, ports and meanings is /work/catalogue.md (and the README's behaviour table).
"""

from __future__ import annotations

from mission.behaviours import (  # noqa: F401  (imported for their @register side effect)
    dock,
    explore,
    follow,
    line_of_sight,
    lost,
    mission_state,
    perceive,
    search,
    staging,
    visibility,
)

TAGS = (
    "PerceiveTargets",
    "IsTargetVisible",
    "IsLineOfSightBlocked",
    "FollowTarget",
    "HoldLastGoal",
    "SearchSweep",
    "Explore",
    "GoToStaging",
    "VisualServoDock",
    "SetMissionState",
)
