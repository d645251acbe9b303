"""A plain-text progress bar on stderr for the command line."""

from __future__ import annotations

import sys
import time


class ProgressBar:
    """``progress(done, total)`` callback drawing ``label [####    ] done/total``.

    On a terminal the bar is redrawn in place (at most ten times a second);
    otherwise (a log file) a line is printed at every tenth. Jobs of fewer
    than ``minimum`` steps print nothing: they are over before a bar helps.
    """

    def __init__(self, label: str, minimum: int = 1, stream=None, width: int = 30):
        self.label, self.minimum, self.width = label, minimum, width
        self.stream = stream if stream is not None else sys.stderr
        self._drawn = 0.0

    def __call__(self, done: int, total: int) -> None:
        if total < self.minimum:
            return
        if not self.stream.isatty():
            if done * 10 // total > (done - 1) * 10 // total:
                print(f"{self.label}: {done} of {total}", file=self.stream, flush=True)
            return
        now = time.monotonic()
        if done < total and now - self._drawn < 0.1:
            return
        self._drawn = now
        filled = self.width * done // total
        print(f"\r{self.label} [{'#' * filled}{' ' * (self.width - filled)}] {done}/{total}",
              end="\n" if done == total else "", file=self.stream, flush=True)
