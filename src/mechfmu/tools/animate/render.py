"""Frames drawn with matplotlib (Agg, no window) and written as GIF, MP4 or HTML.

The figure holds one panel per drawn component (equal axes, to scale, limits fixed over the
whole animation), optional panels of chosen columns against time with a cursor, and the
time. Everything that moves is drawn per frame over a saved background (blitting), so a
frame costs the moving artists only.

Writers: GIF by pillow (a matplotlib dependency, always there); HTML: the GIF inside a page
(or inline in Jupyter); MP4 by imageio-ffmpeg's ffmpeg (optional: the ``video`` extra).
"""

from __future__ import annotations

import base64
import io
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas

from ...cosim.files import atomic_path, atomic_write
from .columns import AnimationError
from .drawings import Drawing, extent
from .frames import Schedule
from .shapes import BAR, BODY, GROUND, GUIDE, KINDS, LINK, OUTLINE, SPRING, TRACE, Shape

# matplotlib options of each kind of shape (shapes.KINDS)
STYLES: dict[str, dict[str, Any]] = {
    LINK: dict(
        color="#1f3b73",
        linewidth=3.0,
        marker="o",
        markersize=5,
        markerfacecolor="white",
        solid_capstyle="round",
    ),
    BAR: dict(color="#1f3b73", linewidth=3.0, solid_capstyle="butt"),
    GROUND: dict(color="#333333", linewidth=0.9),
    SPRING: dict(color="#b8860b", linewidth=1.2),
    BODY: dict(facecolor="#9db4d8", edgecolor="#1f3b73", linewidth=1.0),
    OUTLINE: dict(color="#1f3b73", linewidth=1.0),
    GUIDE: dict(color="#888888", linewidth=0.8, linestyle="--"),
    TRACE: dict(color="#d62728", linewidth=1.0, alpha=0.8),
}
SUFFIXES = (".gif", ".mp4", ".html")
GIF_COLOURS = 128  # the GIF's palette: the drawing's colours and their antialiased blends
GIF_MAX_FPS = 50.0  # GIF delays count centiseconds, and viewers slow delays below 2 cs
DPI = 100


def _even(pixels: float) -> int:
    """``pixels`` rounded to an even whole number (video encoders need even sizes)."""
    return max(2, 2 * round(pixels / 2))


def time_decimals(times: np.ndarray) -> int:
    """Decimals of the time label that tell apart the shown times (s)."""
    steps = np.diff(np.unique(times))
    steps = steps[steps > 0]
    if not len(steps):
        return 3
    return int(min(9, max(0, np.ceil(-np.log10(float(steps.min())) - 1e-9))))


class Animation:
    """An animation of a result: the frames of ``schedule``, each drawing every one of
    ``drawings`` at the row it shows. Displays inline in Jupyter (``_repr_html_``) and
    writes GIF, MP4 or HTML (``save``). ``frame_times`` and ``frame_rows`` say what each
    frame shows; ``shapes(frame)`` gives what it draws, in each component's frame (m)."""

    def __init__(
        self,
        table: pandas.DataFrame,
        drawings: Sequence[Drawing],
        schedule: Schedule,
        panels: Sequence[str] = (),
        width: int = 720,
        title: str = "",
    ) -> None:
        self.table, self.drawings, self.schedule = table, list(drawings), schedule
        self.panels, self.width, self.title = list(panels), int(width), title
        self.times = table.index.to_numpy(dtype=float)
        self._gif: bytes | None = None

    # --- what the frames show -------------------------------------------------------------
    @property
    def frame_rows(self) -> np.ndarray:
        """The result row each frame shows."""
        return self.schedule.rows

    @property
    def frame_times(self) -> np.ndarray:
        """The result time (s) each frame shows (a time of the result)."""
        return self.times[self.schedule.rows]

    @property
    def fps(self) -> float:
        """Frames per second of playback."""
        return self.schedule.fps

    def __len__(self) -> int:
        return len(self.schedule.rows)

    def shapes(self, frame: int) -> dict[str, dict[str, Shape]]:
        """{component: {shape name: Shape}} drawn in frame ``frame``."""
        row = int(self.schedule.rows[frame])
        return {drawing.name: drawing.shapes(row) for drawing in self.drawings}

    # --- drawing ----------------------------------------------------------------------------
    def _figure(self) -> tuple[Any, list[Any]]:
        """The figure, its canvas drawn with everything that does not move, and the
        callables that draw frame k's moving artists (in draw order)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        mechanisms, panels = len(self.drawings), len(self.panels)
        sampled = np.unique(self.schedule.rows[:: max(1, len(self.schedule.rows) // 60)])
        sampled = np.union1d(sampled, [self.schedule.rows[-1]])
        boxes = [extent(drawing, sampled) for drawing in self.drawings]
        aspect = max((box[3] - box[2]) / max(box[1] - box[0], 1e-12) for box in boxes)
        columns = mechanisms + (1 if panels else 0)
        panel_width = self.width * 1.6 / (1.6 * mechanisms + (1.0 if panels else 0.0))
        height = _even(min(max(panel_width * min(max(aspect, 0.55), 1.3), 200), 1.6 * self.width))
        figure = Figure(figsize=(_even(self.width) / DPI, height / DPI), dpi=DPI)
        FigureCanvasAgg(figure)
        grid = figure.add_gridspec(
            max(panels, 1),
            columns,
            width_ratios=[1.6] * mechanisms + ([1.0] if panels else []),
            left=0.07,
            right=0.98,
            bottom=0.1,
            top=0.86,
            wspace=0.3,
            hspace=0.55,
        )
        draws: list[Any] = []
        for index, (drawing, box) in enumerate(zip(self.drawings, boxes)):
            axes = figure.add_subplot(grid[:, index])
            draws.extend(self._mechanism_axes(axes, drawing, box))
        for index, column in enumerate(self.panels):
            axes = figure.add_subplot(grid[index, mechanisms])
            draws.extend(self._panel_axes(axes, column, last=index == panels - 1))
        label = figure.text(0.02, 0.95, "", fontsize=9, family="monospace", animated=True)
        decimals = time_decimals(self.frame_times)
        times = self.frame_times

        def draw_time(frame: int) -> None:
            label.set_text(f"t = {times[frame]:.{decimals}f} s")
            figure.draw_artist(label)

        draws.append(draw_time)
        if self.title:
            figure.suptitle(self.title, fontsize=10, y=0.99)
        return figure, draws

    def _mechanism_axes(
        self, axes: Any, drawing: Drawing, box: tuple[float, float, float, float]
    ) -> list[Any]:
        """Set up ``axes`` for ``drawing`` (equal scale, fixed limits); the callables that
        draw its shapes of frame k."""
        from matplotlib.lines import Line2D
        from matplotlib.patches import Polygon

        xmin, xmax, ymin, ymax = box
        margin = 0.06 * max(xmax - xmin, ymax - ymin)
        axes.set_xlim(xmin - margin, xmax + margin)
        axes.set_ylim(ymin - margin, ymax + margin)
        axes.set_aspect("equal", adjustable="box")
        axes.set_title(f"{drawing.name} ({drawing.MODEL})", fontsize=9)
        axes.tick_params(labelsize=7)
        axes.set_xlabel("x [m]", fontsize=8)
        axes.grid(True, linewidth=0.3, alpha=0.5)
        artists: dict[str, Any] = {}  # shape name -> its Line2D or (bodies) Polygon
        rows = self.schedule.rows

        def draw(frame: int) -> None:
            drawn = drawing.shapes(int(rows[frame]))
            for name, shape in sorted(drawn.items(), key=lambda item: KINDS.index(item[1].kind)):
                artist: Any = artists.get(name)
                if artist is None:
                    if shape.kind == BODY:
                        artist = Polygon(shape.xy, closed=True, animated=True, **STYLES[BODY])
                        axes.add_patch(artist)
                    else:
                        artist = Line2D([], [], animated=True, **STYLES[shape.kind])
                        axes.add_line(artist)
                    artists[name] = artist
                if shape.kind == BODY:
                    artist.set_xy(shape.xy)
                else:
                    artist.set_data(shape.xy[:, 0], shape.xy[:, 1])
                axes.draw_artist(artist)

        return [draw]

    def _panel_axes(self, axes: Any, column: str, last: bool) -> list[Any]:
        """A side panel: ``column`` against time with a cursor at frame k's time."""
        values = self.table[column].to_numpy(dtype=float)
        unit = (self.table.attrs.get("units") or {}).get(column)
        axes.plot(self.times, values, linewidth=1.0, color="#1f77b4")
        axes.set_title(f"{column}" + (f" [{unit}]" if unit else ""), fontsize=8, loc="left")
        axes.tick_params(labelsize=7)
        axes.grid(True, linewidth=0.3, alpha=0.5)
        if last:
            axes.set_xlabel("time [s]", fontsize=8)
        cursor = axes.axvline(self.times[0], color="#d62728", linewidth=0.8, animated=True)
        (dot,) = axes.plot([], [], "o", color="#d62728", markersize=4, animated=True)
        rows = self.schedule.rows

        def draw(frame: int) -> None:
            row = int(rows[frame])
            cursor.set_xdata([self.times[row], self.times[row]])
            dot.set_data([self.times[row]], [values[row]])
            axes.draw_artist(cursor)
            axes.draw_artist(dot)

        return [draw]

    def images(self, frames: Sequence[int] | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """(frame, its RGB image as a (height, width, 3) uint8 array) for each of ``frames``
        (default: every frame, in order)."""
        figure, draws = self._figure()
        canvas = figure.canvas
        canvas.draw()
        background = canvas.copy_from_bbox(figure.bbox)
        for frame in range(len(self)) if frames is None else frames:
            canvas.restore_region(background)
            for draw in draws:
                draw(frame)
            yield frame, np.asarray(canvas.buffer_rgba())[:, :, :3].copy()

    # --- writing ----------------------------------------------------------------------------
    def gif_frames(self) -> tuple[list[int], list[int]]:
        """(the frames the GIF holds, their durations in ms): consecutive frames that show
        the same row are one GIF frame lasting as long as they do together; durations are
        whole centiseconds (GIF's unit) that add up to the frames' times at ``fps``."""
        cumulative = np.round(np.arange(len(self) + 1) * 100.0 / self.fps) * 10.0
        starts = np.flatnonzero(np.r_[True, np.diff(self.frame_rows) != 0])
        ends = np.r_[starts[1:], len(self)]
        durations = [int(cumulative[end] - cumulative[start]) for start, end in zip(starts, ends)]
        return [int(start) for start in starts], durations

    def gif(self) -> bytes:
        """The animation as GIF bytes (pillow; one palette for all frames)."""
        if self._gif is not None:
            return self._gif
        if self.fps > GIF_MAX_FPS:
            raise AnimationError(
                f"fps = {self.fps:g} is more than a GIF plays ({GIF_MAX_FPS:g}: its delays "
                f"count centiseconds): lower fps, or write MP4"
            )
        from PIL import Image

        starts, durations = self.gif_frames()
        # one palette for every frame, from the first and the last (the whole trace)
        ends = np.vstack([image for _, image in self.images([0, len(self) - 1])])
        palette = Image.fromarray(ends).quantize(
            colors=GIF_COLOURS, method=Image.Quantize.MEDIANCUT
        )
        frames = [
            Image.fromarray(image).quantize(palette=palette, dither=Image.Dither.NONE)
            for _, image in self.images(starts)
        ]
        buffer = io.BytesIO()
        frames[0].save(
            buffer,
            format="GIF",
            save_all=True,
            append_images=frames[1:],
            duration=durations,
            loop=0,
            disposal=1,
        )
        self._gif = buffer.getvalue()
        return self._gif

    def html(self) -> str:
        """An HTML fragment showing the animation (the GIF inline, playing and looping)."""
        data = base64.b64encode(self.gif()).decode("ascii")
        text = self.title or "mechfmu animation"
        return f'<img src="data:image/gif;base64,{data}" alt="{text}" />'

    def _repr_html_(self) -> str:
        return self.html()

    def mp4(self, path: Path) -> Path:
        """Write the animation to the MP4 file ``path`` (H.264 by imageio-ffmpeg's ffmpeg)."""
        try:
            import imageio_ffmpeg
        except ImportError:
            raise AnimationError(
                "writing MP4 needs imageio-ffmpeg, which is optional: pip install "
                "'mechfmu[video]' (GIF and HTML need only matplotlib and pillow)"
            ) from None
        with atomic_path(path) as temporary:  # ffmpeg writes it; renamed when complete
            writer = None
            try:
                for _, image in self.images():
                    if writer is None:
                        height, width = image.shape[:2]
                        writer = imageio_ffmpeg.write_frames(
                            str(temporary),
                            (width, height),
                            fps=self.fps,
                            codec="libx264",
                            macro_block_size=2,
                            ffmpeg_log_level="error",
                            output_params=["-f", "mp4"],  # the temporary name ends in .tmp
                        )
                        writer.send(None)
                    writer.send(np.ascontiguousarray(image).tobytes())
            finally:
                if writer is not None:
                    writer.close()
        return path

    def save(self, path: str | Path) -> Path:
        """Write the animation to ``path``: .gif, .mp4 (needs imageio-ffmpeg) or .html (a
        page with the GIF inside). Written whole or not at all. Returns the path."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in SUFFIXES:
            raise AnimationError(
                f"{path}: unknown animation format {path.suffix!r}; use one of "
                + ", ".join(SUFFIXES)
            )
        if suffix == ".mp4":
            return self.mp4(path)
        if suffix == ".gif":
            return atomic_write(path, self.gif())
        title = self.title or "mechfmu animation"
        page = (
            f'<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>{title}</title>'
            f"</head>\n<body>\n{self.html()}\n</body></html>\n"
        )
        return atomic_write(path, page)
