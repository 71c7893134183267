"""How :meth:`wgbragg.render.renderer.Renderer.render` spends a time budget: the dispatches of
``render(seconds=T)`` planned from their measured cost (:class:`TimeBudget`), each a range of
pixels and samples (:class:`PassPlan`), so that the call ends within T plus a small probe at
any image size and leaves a pass it ends inside to be continued (docs/design.md, "Bounded
work")."""

from __future__ import annotations

import dataclasses
import math

__all__ = ["FILL", "PROBE_PATHS", "SLICE_SECONDS", "PassPlan", "TimeBudget"]

PROBE_PATHS = 1024
"""Paths of the first dispatch of :meth:`Renderer.render` with ``seconds`` when its cost per path
is not known yet: the probe whose measured time plans the others (16 workgroups; at most a few
tens of ms for the heaviest scenes on lavapipe)."""
SLICE_SECONDS = 0.25
"""Most seconds :meth:`Renderer.render` with ``seconds`` plans for one dispatch, so that a pass
over a large image is split over pixel ranges and progress (and the end) follow the clock."""
FILL = 0.5
"""Share of the time left that :class:`TimeBudget` plans the next dispatch for: it ends in time
even when the dispatch costs up to 1 / FILL times what the last one measured per path."""


@dataclasses.dataclass(frozen=True)
class PassPlan:
    """One dispatch of :meth:`Renderer.render`: pixels ``first .. first + count - 1`` (in
    row-major order) take ``samples`` paths each."""

    first: int
    count: int
    samples: int

    @property
    def paths(self) -> int:
        """Paths the dispatch traces."""
        return self.count * self.samples


class TimeBudget:
    """The dispatches of :meth:`Renderer.render` with ``seconds``, planned from their measured
    time.

    The first dispatch is a probe of :data:`PROBE_PATHS` paths, unless a cost per path is
    known (``seconds_per_path``, measured by an earlier call). Each later one is planned for
    ``min(SLICE_SECONDS, FILL x (seconds - elapsed))`` at the cost per path the last
    dispatch measured (its wall time, submission and readback included, over its paths),
    and at most 4 times the paths of the last one; planning stops once the time left is
    less than the shortest dispatch measured (no dispatch is quicker) or than a workgroup's
    paths (64). So the render ends within ``seconds`` plus the probe (or plus the first
    dispatch), whatever the image size, as long as a dispatch costs at most ``1 / FILL``
    times per path what the one before it measured.

    A dispatch covers the whole image with up to ``batch`` samples a pixel when the pixel
    cursor is at 0 and it affords that, else one sample a pixel over the next range of pixels
    from the cursor (to the image's end at most; the cursor then wraps to 0): a pass over a
    large image is split into ranges, and pixels before the cursor hold one sample more than
    the others (:meth:`Renderer.sample_counts`).

    Parameters
    ----------
    seconds : float
        Wall-clock budget (> 0).
    pixels : int
        Pixels of the image (>= 1).
    batch : int
        Most samples a pixel one dispatch takes (>= 1).
    cursor : int
        First pixel of the next range (0: every pixel has the same count).
    seconds_per_path : float, optional
        A cost per path measured before; None: probe first.

    Attributes
    ----------
    cursor : int
        The pixel cursor after the dispatches recorded so far.
    seconds_per_path : float or None
        The last measured cost per path.
    """

    MIN_PATHS = 64
    """Fewest paths planned after the first dispatch: one workgroup."""
    GROWTH = 4
    """Most paths a dispatch plans, over the last one's."""

    def __init__(self, seconds: float, pixels: int, batch: int, cursor: int = 0,
                 seconds_per_path: float | None = None):
        self.seconds = float(seconds)
        self.pixels = int(pixels)
        self.batch = int(batch)
        self.cursor = int(cursor)
        self.seconds_per_path = seconds_per_path
        self._last_paths: int | None = None
        # The shortest dispatch measured: none takes less (the fixed cost of a submission).
        self._quickest = math.inf
        self._started = False

    def _shape(self, paths: int) -> PassPlan:
        """The dispatch of about ``paths`` paths (at least one) from the cursor."""
        paths = max(1, paths)
        if self.cursor == 0 and paths >= self.pixels:
            return PassPlan(0, self.pixels, min(self.batch, paths // self.pixels))
        return PassPlan(self.cursor, min(paths, self.pixels - self.cursor), 1)

    def next(self, elapsed: float) -> PassPlan | None:
        """The next dispatch, or None when the time is spent.

        Parameters
        ----------
        elapsed : float
            Seconds since the render began.
        """
        if not self._started:
            self._started = True
            paths = PROBE_PATHS
            if self.seconds_per_path is not None:
                paths = max(paths, self._affordable(elapsed))
            return self._shape(paths)
        left = self.seconds - elapsed
        if left <= self._quickest or self.seconds_per_path is None:
            return None
        paths = self._affordable(elapsed)
        if self._last_paths is not None:
            paths = min(paths, self.GROWTH * self._last_paths)
        if paths < self.MIN_PATHS:
            return None
        return self._shape(paths)

    def _affordable(self, elapsed: float) -> int:
        """Paths that fit the next dispatch's share of the time left, at the last cost."""
        budget = min(SLICE_SECONDS, FILL * (self.seconds - elapsed))
        if budget <= 0.0:
            return 0
        return int(min(budget / self.seconds_per_path, self.pixels * self.batch))

    def record(self, plan: PassPlan, seconds: float) -> None:
        """Take a dispatch's measured wall time; advance the cursor past its pixels."""
        self.seconds_per_path = max(float(seconds), 1e-9) / plan.paths
        self._last_paths = plan.paths
        self._quickest = min(self._quickest, float(seconds))
        if plan.count < self.pixels:
            self.cursor = (plan.first + plan.count) % self.pixels
