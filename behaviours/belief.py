"""Where a lost target can be: its last position plus its maximum speed × time, minus what the camera has seen.

One :class:`TargetBelief` per loss (per target, on the blackboard at ``/target/beliefs``), started by the
first LOST or SEARCH leaf that ticks after the target was last seen and kept up to date by whichever of
them ticks (every tick, exactly one does), so the search rungs know what LOST and the turn before them
already looked at.

On the coarse search grid (behaviours/search_grid.py):

* ``reach`` — how far each cell is from the last position along paths the target can walk (it does not
  walk through walls): at time t the target can be in the cells with reach ≤ r0 + ``speed_mps`` · (t −
  last seen);
* ``possible`` — where the target can be now: it starts as the cells within reach when the loss is
  decided, and from then on it is a front that walks: every ``resolution / speed_mps`` seconds it grows
  by one cell into the free cells beside it (never beyond the reach), and every camera view clears the
  cells it sees. A target cannot cross the camera's view unseen, so the front does not leak behind the
  robot past what it is looking at; and a place looked at a while ago fills again once the target could
  have walked back into it from where it might be;
* ``density`` — how likely the target is in each cell: it starts evenly on the cells the front starts
  from (round the last position), every step of the front it spreads a little into the free cells beside
  it (the target moves; the total is kept), and every camera view leaves MISS of it in the cells it sees
  (the camera can miss a marker);
* ``seen`` — every cell the camera has seen since the loss (in its horizontal field of view, within
  ``view_range_m`` — a marker farther than that is too small to read — and not hidden by the map's
  obstacles or what the lidar sees): what the coverage rung has covered.

Why a walking front rather than "within reach and never seen": a target cannot get behind the robot without
crossing what the camera looks at, so the places behind it are not worth a look; and a place seen once is
not cleared for good — a target hidden behind a moving cart walks back into it.

Viewpoints are ranked on :meth:`weights`: ``possible`` times ``density`` times a prior. The front says
where the target *can* be; the density how likely: a place just looked at that the front has walked back
into is worth little until the likelihood of the places beside it, still unseen, has spread into it, and a
far corner the front reached by walking round behind the robot is worth little next to the places near
where the target vanished. The prior favours the target having walked on the way it was going (a band
round its last position carried on along its last velocity), never zero elsewhere: the density spreads
evenly, a walking target does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from mission.behaviours.search_grid import (
    TARGET_RADIUS_M,
    SearchGrid,
    dilate_once,
    travel_distances,
    view_cells,
)

DEFAULT_SPEED_MPS = 1.0  # how fast the target may walk unseen (a brisk walk), until SearchBelief sets its own
DEFAULT_VIEW_RANGE_M = 4.0  # how far the camera can read the target's marker
SEED_RADIUS_M = 0.3  # the belief starts as the cells this close to the last position
PRIOR_FLOOR = 0.05  # prior weight far from the predicted walk (never zero: the target may turn)
PRIOR_SIGMA_M = 1.0  # width of the band round the predicted walk
BEHIND_FLOOR = 0.2  # behind the last position the floor fades to this fraction of PRIOR_FLOOR (see _prior)
PRIOR_HORIZON_S = 4.0  # how far along its last velocity the predicted walk goes
MISS = 0.2  # of a cell's likelihood, what a camera view of it leaves (a marker turned away or blurred is missed)
SPREAD = 0.8  # of a cell's likelihood, what moves to the free cells beside it each step of the front
SPREADS_PER_STEP = 4  # a walking target strays faster than one spread a step: ~1.2 m in 3 s, not 0.6
WANDER_FLOOR = 0.05  # what a possible place the density has not reached still counts (see weights)


@dataclass
class TargetBelief:
    """One loss's belief of where the target can be, and what the camera has seen since."""

    target: str
    episode: float  # the track's last_seen this belief is about (one belief per loss)
    last_xy: tuple[float, float]
    velocity: tuple[float, float] | None
    grid: SearchGrid = field(repr=False)
    reach: np.ndarray = field(repr=False)  # float H×W: metres from the last position along walkable paths
    seen: np.ndarray = field(repr=False)  # bool H×W: seen by the camera since the loss
    prior: np.ndarray = field(repr=False)  # float32 H×W: weight of each cell (the predicted walk)
    started: float  # when the belief was made (the first LOST / SEARCH tick)
    updated: float  # the time `possible` is for
    speed_mps: float = DEFAULT_SPEED_MPS
    view_range_m: float = DEFAULT_VIEW_RANGE_M
    initial_mass: float = 0.0
    looks: int = 0  # camera views applied
    density: np.ndarray | None = field(default=None, repr=False)  # float32 H×W: how likely it is there (module)
    front: np.ndarray | None = field(default=None, repr=False)  # bool H×W: where it can be now (see the module)
    free: np.ndarray | None = field(default=None, repr=False)  # bool H×W: where the target can stand
    grown_to: float = 0.0  # the time the front has walked to
    grows: int = 0  # growth steps so far (the kernel alternates)
    log: list[str] = field(default_factory=list)  # what each rung did, for the reason the search gives

    @property
    def radius_m(self) -> float:
        """How far from its last position the target can be by now."""
        return SEED_RADIUS_M + self.speed_mps * max(0.0, self.updated - self.episode)

    @property
    def reachable(self) -> np.ndarray:
        """Bool H×W: where the target could walk to at all from where it was lost."""
        return np.isfinite(self.reach)

    @property
    def possible(self) -> np.ndarray:
        """Bool H×W: where the target can be now (the walking front, cleared by every view since)."""
        if self.front is None:
            return (self.reach <= self.radius_m) & ~self.seen
        return self.front

    @classmethod
    def start(
        cls,
        target: str,
        episode: float,
        last_xy: tuple[float, float],
        velocity: tuple[float, float] | None,
        sg: SearchGrid,
        now: float,
        speed_mps: float = DEFAULT_SPEED_MPS,
        view_range_m: float = DEFAULT_VIEW_RANGE_M,
    ) -> TargetBelief:
        """The belief at `now` for a target last seen at `last_xy` at time `episode`."""
        free = sg.target_free(TARGET_RADIUS_M)
        xs, ys = sg.centres()
        d = np.where(free, np.hypot(xs - last_xy[0], ys - last_xy[1]), np.inf)
        if np.isfinite(d).any():  # last seen against a wall or in clutter: from the nearest place it can stand
            start_cell = tuple(int(v) for v in np.unravel_index(int(np.argmin(d)), d.shape))
            reach = travel_distances(free, start_cell, sg.resolution)  # type: ignore[arg-type]
            reach = np.where(free, reach + float(d[start_cell]), np.inf)
        else:
            reach = np.full(sg.shape, np.inf)
        belief = cls(
            target=target,
            episode=episode,
            last_xy=last_xy,
            velocity=velocity,
            grid=sg,
            reach=reach,
            seen=np.zeros(sg.shape, dtype=bool),
            prior=_prior(xs, ys, last_xy, velocity),
            started=now,
            updated=now,
            speed_mps=speed_mps,
            view_range_m=view_range_m,
            free=free,
        )
        belief.front = (reach <= belief.radius_m) & free
        belief.density = belief.front.astype(np.float32)
        belief.grown_to = now
        belief.initial_mass = belief.mass()
        return belief

    # -- time and views ---------------------------------------------------------------------------
    def grow(self, now: float) -> None:
        """Let the target walk on to `now`: the reach grows at speed_mps, the front a cell per cell's walk."""
        self.updated = max(self.updated, now)
        if self.front is None or self.free is None or self.speed_mps <= 0:
            return
        step_s = self.grid.resolution / self.speed_mps
        if self.grown_to + step_s > self.updated:
            return
        within = (self.reach <= self.radius_m) & self.free
        if not self.front.any():  # the views cleared all of it: the camera missed the target where it looked,
            self.front = within & ~self.seen  # so it can be anywhere within reach not yet seen
        while self.grown_to + step_s <= self.updated:
            self.front = dilate_once(self.front, self.grows) & within
            if self.density is not None:
                for _ in range(SPREADS_PER_STEP):
                    self.density = spread(self.density, self.free)
            self.grows += 1
            self.grown_to += step_s

    def observe(self, view: np.ndarray) -> None:
        """The camera saw the cells of `view` (bool H×W) and the target was not there.

        The loss is decided a few frames after the last sighting, in plain view or not: when the first view
        would clear every place the target can be, it vanished where the camera looks (a missed detection,
        a marker turned away), and that view clears nothing of the front."""
        self.seen |= view
        if self.front is not None:
            left = self.front & ~view
            if left.any() or self.looks > 0:
                self.front = left
                if self.density is not None:
                    self.density[view] *= MISS
        self.looks += 1

    def look(self, now: float, camera: tuple[float, float], yaw: float, hfov: float, blocked: np.ndarray) -> None:
        """Grow to `now`, then clear what a camera at `camera` facing `yaw` sees (`blocked`: what hides)."""
        self.grow(now)
        self.observe(view_cells(self.grid, blocked, camera, yaw, hfov, self.view_range_m))

    # -- what is left -----------------------------------------------------------------------------
    def weights(self) -> np.ndarray:
        """Float H×W: how much each cell is worth looking at (0 where the target cannot be).

        A cell the front has walked back into since it was seen is worth less than one never seen until the
        places beside it, unseen, have spread their likelihood into it: the front says the target *could* be
        there again, but of all the ways it could have gone, few lead back into a place just looked at.
        Without the density a robot keeps re-sweeping what it just cleared (hide_and_wait: the band along the
        target's last heading, swept four times while it waited behind the crates).

        The density is scaled so that its likeliest possible cell counts 1: it thins as it spreads, and what
        ranks views (a window worth less than half a cell is not worth a visit; a turn that shows a third of
        the weight) is measured in cells. Every possible cell keeps WANDER_FLOOR: the spread is a slow, even
        wander, and a target that walked straight off the way it was not going (two_rooms: through the
        doorway, then along the wall) is where the density has hardly reached — without the floor those
        places count for nothing next to the ones just looked at (two_rooms seeds 3, 12, 13: 8.5 s → 12 s)."""
        possible = self.possible
        if self.density is None or not possible.any():
            return possible * self.prior
        peak = float(self.density[possible].max())
        if peak <= 0:
            return possible * self.prior
        return possible * self.prior * (WANDER_FLOOR + (1.0 - WANDER_FLOOR) * self.density / peak)

    def mass(self) -> float:
        return float(self.weights().sum())

    def unseen(self) -> np.ndarray:
        """Bool H×W: places the target could reach from where it was lost that the camera has not seen."""
        return self.reachable & ~self.seen

    def seen_fraction(self) -> float:
        """Of the places reachable from where the target was lost, the fraction the camera has seen."""
        reachable = self.reachable
        total = int(reachable.sum())
        return 1.0 if total == 0 else float((reachable & self.seen).sum()) / total


def spread(density: np.ndarray, free: np.ndarray) -> np.ndarray:
    """One step of the target's unseen walk: SPREAD of each free cell's likelihood goes, in equal shares, to
    the free cells among its eight neighbours; none is lost into walls (a cell without a free neighbour
    keeps all of its own)."""
    free_f = free.astype(np.float32)
    ring = np.ones((3, 3), np.float32)
    ring[1, 1] = 0.0
    neighbours = cv2.filter2D(free_f, -1, ring, borderType=cv2.BORDER_CONSTANT)
    moving = np.where(neighbours > 0, SPREAD * density, 0.0).astype(np.float32)
    inflow = cv2.filter2D(moving / np.maximum(neighbours, 1.0), -1, ring, borderType=cv2.BORDER_CONSTANT)
    return ((density - moving + inflow) * free_f).astype(np.float32)


def _prior(
    xs: np.ndarray, ys: np.ndarray, last: tuple[float, float], velocity: tuple[float, float] | None
) -> np.ndarray:
    """PRIOR_FLOOR everywhere, up to 1 + PRIOR_FLOOR on the target's predicted walk (last velocity).

    Behind the last position (against its last velocity) the floor fades to BEHIND_FLOOR of itself within
    PRIOR_SIGMA_M: a walking target seldom turns back the way it came, which is also the way the robot
    followed it and looked. Without the fade, the wide area behind at the floor weight outweighs the small
    place round the corner it went behind, and the search looks back first."""
    floor = np.full(xs.shape, PRIOR_FLOOR)
    if velocity is None or math.hypot(*velocity) < 0.05:
        d = np.hypot(xs - last[0], ys - last[1])
    else:
        ex, ey = last[0] + velocity[0] * PRIOR_HORIZON_S, last[1] + velocity[1] * PRIOR_HORIZON_S
        vx, vy = ex - last[0], ey - last[1]
        along = ((xs - last[0]) * vx + (ys - last[1]) * vy) / (vx * vx + vy * vy)
        t = np.clip(along, 0.0, 1.0)
        d = np.hypot(xs - (last[0] + t * vx), ys - (last[1] + t * vy))
        behind = np.maximum(-along, 0.0) * math.hypot(vx, vy)  # metres behind the last position
        floor *= BEHIND_FLOOR + (1.0 - BEHIND_FLOOR) * np.exp(-(behind**2) / (2 * PRIOR_SIGMA_M**2))
    return (floor + np.exp(-(d**2) / (2 * PRIOR_SIGMA_M**2))).astype(np.float32)
