"""Seeing the mission: tree drawings (text, DOT, SVG, PNG, HTML), tick logs, the live web view and recordings.

Every drawing starts from one data shape, :class:`mission.viz.model.VizNode`, built from a live tree's
:func:`mission.core.snapshot.snapshot`, from a tree file's static description, or from a recorded tick; and
every picture of a tree uses the one layout in :mod:`mission.viz.layout`.
"""
