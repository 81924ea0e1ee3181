"""Benchmark plots are written like every other whole file (core/files.py): a run that fails or is
stopped while plotting leaves the previous picture in bench/results/, never a truncated PNG or a temp file."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pytest

from bench.common import save_figure


def _figure(title: str) -> plt.Figure:
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0, 1], [0, 1])
    ax.set_title(title)
    return fig


def test_a_plot_is_written_as_a_png_and_its_figure_closed(tmp_path):
    fig = _figure("ok")
    save_figure(fig, tmp_path / "results" / "plot.png")
    assert (tmp_path / "results" / "plot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert fig.number not in plt.get_fignums()


def test_a_plot_that_fails_to_render_leaves_the_previous_picture_and_frees_its_figure(tmp_path):
    path = tmp_path / "plot.png"
    save_figure(_figure("first run"), path)
    before = path.read_bytes()
    broken = _figure(r"$\notacommand{x}$")  # mathtext fails only when the figure is drawn
    with pytest.raises(ValueError):
        save_figure(broken, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["plot.png"]  # no temp file left behind
    assert broken.number not in plt.get_fignums()
