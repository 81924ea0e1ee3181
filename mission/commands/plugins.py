"""`mission plugins`: every installed plugin, by kind (core/plugins.py), one line each."""

from __future__ import annotations

import argparse

from mission.core import plugins
from mission.perception_plugins import registry


def main(args: argparse.Namespace) -> int:
    kinds = [(plugins.PERCEPTION_SOURCES, registry.describe())]
    kinds += [(kind, plugins.describe(kind)) for kind in (plugins.BEHAVIOURS, plugins.VLM_CLIENTS)]
    if not kinds[0][1]:
        print(f"no perception plugins installed (entry-point group {plugins.PERCEPTION_SOURCES.group})")
        return 1
    width = max(len(info.name) for _kind, infos in kinds for info in infos)
    for n, (kind, infos) in enumerate(kinds):
        if n:  # perception sources first and unheaded, as before the other kinds were listed
            print(f"{kind.group} ({kind.interface}):" + ("" if infos else " none installed"))
        for info in infos:
            text = info.description if info.error is None else f"BROKEN: {info.error}"
            print(f"{info.name:<{width}}  {text}")
    return 0
