"""Animations of the mechanisms from any result: ``mechfmu animate``, ``mechfmu run --animate``
and ``mechfmu.animate(df)``.

A result animates when it holds the outputs of the ``geometry`` effect of its mechanism
components (the joints' positions, runtime/physics/joint_positions.py): ``mechfmu run SCENE
--animate`` and ``mechfmu.simulate(scene, geometry=True)`` switch the effect on and record
them. Each component is drawn to scale in its own frame (drawings.py) at the rows frames.py
picks (real time by default), and written by render.py: GIF (pillow), HTML (the GIF in a
page; inline in Jupyter) or MP4 (imageio-ffmpeg, optional: the ``video`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from os import PathLike

import pandas

from .columns import AnimationError, drawn_components
from .drawings import drawing_of
from .frames import schedule
from .render import SUFFIXES, Animation
from .scene import with_geometry

__all__ = ["SUFFIXES", "Animation", "AnimationError", "animate", "speed_hint", "with_geometry"]

DEFAULT_FPS = 25.0  # frames per second: a whole number of GIF centiseconds per frame (4)
DEFAULT_WIDTH = 720  # pixels


def _table(result: pandas.DataFrame | str | PathLike) -> pandas.DataFrame:
    """``result`` as a result DataFrame: itself, or the result CSV it names (read_result,
    with the metadata JSON beside it)."""
    if isinstance(result, pandas.DataFrame):
        return result
    if isinstance(result, (str, PathLike)):
        from ...io import read_result

        return read_result(result)
    raise TypeError(
        f"result must be a DataFrame or a result CSV's path, got {type(result).__name__}"
    )


def speed_hint(animation: Animation) -> str | None:
    """A hint when ``animation`` has too few frames to show motion (a short result played
    in real time): the speed that plays it in about 4 s; None otherwise."""
    if len(animation) >= 8:
        return None
    times = animation.times
    span = float(times[-1] - times[0])
    speed = span / 4.0
    return (
        f"{len(animation)} frame(s): the result spans {span:g} s, played at speed "
        f"{animation.schedule.speed:g}; --speed {speed:.3g} plays it in about 4 s"
    )


def animate(
    result: pandas.DataFrame | str | PathLike,
    *,
    speed: float = 1.0,
    fps: float = DEFAULT_FPS,
    panels: Sequence[str] = (),
    width: int = DEFAULT_WIDTH,
    title: str | None = None,
) -> Animation:
    """An animation of every mechanism in ``result`` (a DataFrame of mechfmu.simulate or
    read_result, or a result CSV's path), drawn to scale from its geometry columns.

    ``speed``: playback speed against real time (1: real time, 0.1: ten times slower);
    ``fps``: frames per second; ``panels``: columns to plot against time beside the
    mechanisms, with a cursor at each frame's time; ``width``: pixels; ``title``: above the
    drawing (default: the scene's name and the speed).

    The returned Animation shows inline in Jupyter and writes ``.save("x.gif")`` (or .mp4,
    .html). AnimationError (a ValueError) when the result lacks the geometry columns (the
    message names the effect to switch on), for an unknown panel column, or a speed or
    frame rate that is not positive.
    """
    table = _table(result)
    components = drawn_components(table)
    unknown = [name for name in panels if name not in table.columns]
    if unknown:
        raise AnimationError(
            f"panel column(s) {', '.join(unknown)} not in the result; its columns: "
            + ", ".join(table.columns)
        )
    if not (isinstance(width, int) and 100 <= width <= 4000):
        raise AnimationError(f"width = {width!r} must be a whole number of pixels in [100, 4000]")
    frames = schedule(table.index.to_numpy(dtype=float), speed, fps)
    if title is None:
        scene = table.attrs.get("scene")
        pace = "real time" if speed == 1.0 else f"{speed:g} x real time"
        title = f"{scene} ({pace})" if scene else pace
    return Animation(table, [drawing_of(c) for c in components], frames, panels, width, title)
