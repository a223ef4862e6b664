"""Campaign progress on stderr: a live bar on a terminal, plain lines otherwise.

A terminal gets ``label [#######.....] 12/100 trials  1.6/min  ETA 55 min`` redrawn in
place; a pipe or file gets one such line whenever another tenth of the trials is done
or a minute has passed, so logs stay short.  The rate counts only trials run now, not
those found finished on resume.  Steps run within unfinished trials are shown too
(``3/10 trials + 45 steps``; a pipe gets such a line at most every ``STEP_LINE_S``), so
a long trial is seen to move.
"""

from __future__ import annotations

import sys
import time

STEP_LINE_S = 10.0


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class Progress:
    def __init__(self, label: str = "", stream=None, interactive: bool | None = None, width: int = 24):
        self.label, self.stream, self.width = label, stream or sys.stderr, width
        self.interactive = self.stream.isatty() if interactive is None else interactive
        self.total = self.done = self.resumed = 0
        self.steps_per_trial = self.steps_done = 0
        self.t0 = self.last_line = 0.0
        self.last_fraction = -1.0

    def start(self, total: int, done: int = 0, steps_per_trial: int = 0) -> None:
        self.total, self.done, self.resumed = total, done, done
        self.steps_per_trial, self.steps_done = steps_per_trial, 0
        self.t0 = self.last_line = time.monotonic()
        self._emit(force=True)

    def advance(self, n: int = 1) -> None:
        self.done += n
        self._emit()

    def step(self) -> None:
        """One more step run (in this process)."""
        self.steps((self.steps_done or 0) + 1)

    def steps(self, n: int) -> None:
        """``n`` steps run so far by this campaign's trials (finished or not)."""
        if n != self.steps_done:
            self.steps_done = n
            if self.interactive or time.monotonic() - self.last_line >= STEP_LINE_S:
                self._emit(force=not self.interactive)

    def close(self) -> None:
        if self.interactive:
            self.stream.write("\n")
        elif self.done != self.total:
            self._emit(force=True)
        self.stream.flush()

    def line(self) -> str:
        elapsed = time.monotonic() - self.t0
        ran = self.done - self.resumed
        rate = ran / elapsed if elapsed > 0 and ran else 0.0
        eta = (self.total - self.done) / rate if rate else None
        text = f"{self.done}/{self.total} trials"
        partial = self.steps_done - (self.done - self.resumed) * self.steps_per_trial if self.steps_per_trial else 0
        if partial > 0 and self.done < self.total:
            text += f" + {partial} steps"
        if ran:
            text += f"  {60 * rate:.1f}/min  ETA {_duration(eta) if eta is not None else '?'}"
        if self.interactive:
            filled = int(self.width * self.done / max(self.total, 1))
            text = f"[{'#' * filled}{'.' * (self.width - filled)}] " + text
        return f"{self.label} {text}".strip()

    def _emit(self, force: bool = False) -> None:
        if self.interactive:
            self.stream.write("\r" + self.line() + "  ")
            self.stream.flush()
            return
        now = time.monotonic()
        fraction = self.done / max(self.total, 1)
        if force or fraction - self.last_fraction >= 0.1 or now - self.last_line >= 60 or self.done == self.total:
            self.stream.write(self.line() + "\n")
            self.stream.flush()
            self.last_fraction, self.last_line = fraction, now
