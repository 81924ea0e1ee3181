"""GiveUpSearch: the last rung of the search ladder — end the loss with a reason a person can act on.

A search that never ends hides a target that has gone (out of the map, into a room the map does not
have) behind a robot that looks busy. When every rung before it has failed, this leaf sets the mission
state FAILED and fails with what was done: how long ago and where the target was last seen, what each
rung did (the loss's belief keeps their account), and how much of the space the target could have walked
to the camera has seen — so "not found" reads as "not here", or as "not where this robot could look".
"""

from __future__ import annotations

from dataclasses import dataclass

import py_trees

from mission.behaviours.belief import TargetBelief
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState


class GiveUpSearch(MissionLeaf):
    """SEARCH d: set FAILED and fail, with the search's account of where it looked as the reason."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS, bbk.BELIEFS)
    COMMANDS = True
    params: Params

    def update(self) -> py_trees.common.Status:
        name = self.params.target
        track = self.track(name)
        self.halt()
        self.set_state(MissionState.FAILED)
        if track is None or track.last_seen is None:
            return self.fail(f"SEARCH gave up: {name} was never seen")
        ago = self.now() - track.last_seen
        where = ""
        if track.pose_map is not None:
            where = f" at ({float(track.pose_map[0, 3]):.2f}, {float(track.pose_map[1, 3]):.2f})"
        belief: TargetBelief | None = (self.read(bbk.BELIEFS) or {}).get(name)
        if belief is None or belief.episode != track.last_seen:
            return self.fail(f"SEARCH gave up: {name} not found {ago:.0f} s after it was last seen{where}")
        done = "; ".join(belief.log) or "nothing"
        return self.fail(
            f"SEARCH gave up: {name} not found {ago:.0f} s after it was last seen{where}: {done}; the camera saw "
            f"{100 * belief.seen_fraction():.0f} % of where it could have walked — it has left, or hides where "
            "this robot cannot look"
        )
