"""The tree at the key moments of a run, for `mission run --report DIR`: one SVG per mission-state transition
(and the final tick) under ``DIR/trees/``, and ``DIR/report.html`` showing them with the run's summary
and the report pictures (trajectories.png, timeline.png) beside them.

Why at transitions: a state change (EXPLORE → DOCK, FOLLOW → LOST…) is when a reader asks "which branch
decided that?", and the tree at that tick answers it.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

from mission.core.observers import RunObserver, Tick
from mission.viz.model import apply_tick, from_snapshot
from mission.viz.output import write_output
from mission.viz.probe import TickProbe, probe_for, release_probe
from mission.viz.style import STATE_COLOURS
from mission.viz.svg import render_svg

MAX_MOMENTS = 40  # a flapping state keeps the first ones and the final tick


def perception_label(provenance: dict[str, Any] | None) -> str:
    """The perception plugins a run used, as its result line and report name them: ``aruco``, or
    ``vlm + apriltag``; an instance named otherwise shows its plugin (``front (aruco)``)."""
    names = []
    for p in (provenance or {}).get("perception_plugins") or []:
        name, plugin = p.get("name"), p.get("plugin")
        names.append(str(name) if name == plugin or not plugin else f"{name} ({plugin})")
    return " + ".join(names)


class TransitionTrees(RunObserver):
    """A run observer that keeps the tree at each state transition and writes them at the end.

    One tree: in a run whose trees come and go (an action server's goals, ``on_tree``) the first one the run
    has, until it stops or is replaced."""

    def __init__(self, out_dir: str | Path) -> None:
        self.out_dir = Path(out_dir)
        self.moments: list[dict[str, Any]] = []
        self._last_state: str | None = None
        self._last_rec: dict[str, Any] | None = None
        self._probe: TickProbe | None = None
        self._tree: dict[str, Any] | None = None
        self.written: list[Path] = []

    def on_start(self, runner: Any) -> None:
        if runner.tree is not None:  # none: an action server's run before its first goal (on_tree brings it)
            self._watch(runner)

    def on_tree(self, runner: Any) -> None:
        if self._tree is None:
            if runner.tree is not None:
                self._watch(runner)
        elif self._probe is not None:  # the tree reported on stopped or was replaced: its moments end here
            release_probe(self._probe)
            self._probe = None

    def _watch(self, runner: Any) -> None:
        self._probe = probe_for(runner)
        from mission.viz.model import to_dict

        self._tree = to_dict(self._probe.static)

    def on_tick(self, runner: Any, tick: Tick) -> None:
        ground_truth = tick.ground_truth
        if self._probe is None:
            return
        rec = self._probe.record(runner, ground_truth)
        self._last_rec = rec
        if rec["state"] != self._last_state and len(self.moments) < MAX_MOMENTS:
            previous = self._last_state
            self.moments.append({**rec, "from": previous})
        self._last_state = rec["state"]

    def on_end(self, runner: Any, outcome: Any) -> None:
        if self._probe is not None:
            release_probe(self._probe)
            self._probe = None
        if self._last_rec is not None and (not self.moments or self.moments[-1]["tick"] != self._last_rec["tick"]):
            self.moments.append({**self._last_rec, "from": self._last_rec["state"], "final": True})
        elif self.moments:
            self.moments[-1]["final"] = True
        self.write(outcome)

    def write(self, outcome: Any = None) -> list[Path]:
        """The SVGs and report.html; returns the files written."""
        if self._tree is None:
            return []
        tree_dir = self.out_dir / "trees"
        for old in tree_dir.glob("[0-9][0-9]_t*.svg"):  # an earlier run's moments in a reused folder: not this run's
            old.unlink(missing_ok=True)
        entries = []
        for k, m in enumerate(self.moments):
            root = apply_tick(from_snapshot(self._tree), m["nodes"])
            state = m["state"] or "no state"
            what = (
                "final tick" if m.get("final") and m.get("from") == m["state"] else f"{m['from'] or 'start'} → {state}"
            )
            title = f"t = {m['t'] or 0:.1f} s · tick {m['tick']} · {what}"
            name = f"{k:02d}_t{(m['t'] or 0):07.1f}_{(m['state'] or 'none').lower()}.svg"
            path = write_output(tree_dir / name, render_svg(root, feedback=True, title=title).encode("utf-8"))
            self.written.append(path)
            entries.append((m, what, path.relative_to(self.out_dir)))
        self.written.append(write_output(self.out_dir / "report.html", self._html(entries, outcome).encode("utf-8")))
        return self.written

    def _html(self, entries: list[tuple[dict[str, Any], str, Path]], outcome: Any) -> str:
        out = outcome.to_json() if hasattr(outcome, "to_json") else (outcome or {})
        ok = out.get("success")
        verdict = "SUCCESS" if ok else ("FAILURE" if ok is not None else "")
        facts = [
            ("scenario", out.get("scenario")),
            ("seed", out.get("seed")),
            ("reason", out.get("reason")),
            ("final state", out.get("final_state")),
            ("tree status", out.get("tree_status")),
            ("simulated", f"{out.get('sim_time_s', 0):.1f} s" if "sim_time_s" in out else None),
            ("wall time", f"{out.get('wall_time_s', 0):.1f} s" if "wall_time_s" in out else None),
            ("ticks", out.get("ticks")),
        ]
        facts.append(("perception", perception_label(out.get("provenance"))))
        metrics = out.get("metrics") or {}
        dock = metrics.get("dock")
        if dock:
            facts.append(
                (
                    "dock accuracy",
                    f"lateral {dock['lateral_m'] * 100:.1f} cm, distance {dock['distance_m'] * 100:.1f} cm, "
                    f"skew {dock['skew_deg']:.1f}° (stand-off {dock['standoff_m'] * 100:.0f} cm)",
                )
            )
        for key in ("loss_events", "loss_events_recovered", "collisions"):
            if key in metrics:
                facts.append((key.replace("_", " "), metrics[key]))
        rows = "".join(
            f"<tr><td>{html.escape(str(k))}</td><td>{html.escape(str(v))}</td></tr>" for k, v in facts if v is not None
        )
        cards = []
        for m, what, rel in entries:
            colour = STATE_COLOURS.get(m["state"], "#5f6368")
            active = " › ".join(m.get("active", [])[-3:])
            cards.append(
                f'<figure class="moment"><figcaption><span class="pill" style="background:{colour}">'
                f"{html.escape(m['state'] or '—')}</span> t = {m['t'] or 0:.1f} s · tick {m['tick']} · "
                f'{html.escape(what)}<br><span class="muted">{html.escape(active)}</span></figcaption>'
                f'<a href="{rel.as_posix()}"><img src="{rel.as_posix()}" alt="tree at tick {m["tick"]}"></a></figure>'
            )
        verdict_colour = "#1e8e3e" if ok else "#d93025"
        return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>mission report — {html.escape(str(out.get("scenario", "")))}</title>
<style>
body {{ font-family: 'DejaVu Sans', Verdana, Arial, sans-serif; margin: 0; background: #eef0f3; color: #202124;
  font-size: 13px; }}
header {{ background: #1f2633; color: #e8eaed; padding: 12px 20px; display: flex; gap: 16px; align-items: center; }}
header h1 {{ font-size: 18px; margin: 0; }}
.verdict {{ padding: 3px 12px; border-radius: 12px; font-weight: bold; background: {verdict_colour}; color: #fff; }}
main {{ padding: 14px 20px; }}
.row {{ display: flex; gap: 14px; flex-wrap: wrap; align-items: stretch; }}
.card {{ background: #fff; border-radius: 8px; box-shadow: 0 1px 3px rgba(0,0,0,.12); padding: 10px 14px; }}
table td {{ padding: 2px 10px 2px 0; }} table td:first-child {{ color: #6b7280; }}
img.pic {{ height: 250px; max-width: 100%; }}
h2 {{ font-size: 15px; margin: 18px 0 8px; }}
.moment {{ background: #fff; border-radius: 8px; box-shadow: 0 1px 3px rgba(0,0,0,.12); margin: 0;
  padding: 10px 14px; }}
.moments {{ display: grid; grid-template-columns: repeat(auto-fill, minmax(560px, 1fr)); gap: 14px; }}
.moment img {{ width: 100%; }}
.pill {{ color: #fff; border-radius: 10px; padding: 1px 9px; font-weight: bold; }}
.muted {{ color: #6b7280; }}
</style></head><body>
<header><h1>mission report</h1><span class="verdict">{verdict}</span>
<span>{html.escape(str(out.get("scenario", "")))} · seed {html.escape(str(out.get("seed", "")))}</span></header>
<main>
<div class="row"><div class="card"><table>{rows}</table></div>
<div class="card"><img class="pic" src="trajectories.png" alt="trajectories"></div>
<div class="card"><img class="pic" src="timeline.png" alt="timeline"></div></div>
<h2>The tree at each state transition</h2>
<div class="moments">{"".join(cards) or '<p class="muted">no ticks recorded</p>'}</div>
</main></body></html>
"""
