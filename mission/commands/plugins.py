"""`mission plugins`: what perception sources are installed, one line each."""

from __future__ import annotations

import argparse

from mission.perception_plugins import registry


def main(args: argparse.Namespace) -> int:
    infos = registry.describe()
    if not infos:
        print("no perception plugins installed (entry-point group mission.perception_plugins)")
        return 1
    width = max(len(i.name) for i in infos)
    for info in infos:
        text = info.description if info.error is None else f"BROKEN: {info.error}"
        print(f"{info.name:<{width}}  {text}")
    return 0
