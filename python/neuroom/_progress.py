"""Progress arguments: a callable ``(stage, step, total)``, or a ``tqdm`` bar turned into one."""

from __future__ import annotations

from typing import Any, Callable

ProgressCallback = Callable[[str, int, int], object]


def as_callback(progress: Any) -> ProgressCallback:
    """Returns ``progress`` when it is a plain callable; a ``tqdm``-like bar (``update``, ``total``,
    ``n``) becomes a callback that moves the bar and names the stage in its description."""
    if hasattr(progress, "update") and hasattr(progress, "total") and hasattr(progress, "n"):
        bar = progress

        def move_bar(stage: str, step: int, total: int) -> None:
            if bar.total != total:
                bar.reset(total=total)
            if stage:
                bar.set_description(stage, refresh=False)
            bar.update(step - bar.n)

        return move_bar
    if callable(progress):
        callback: ProgressCallback = progress
        return callback
    raise TypeError("progress: expected a callable (stage, step, total) or a tqdm bar")
