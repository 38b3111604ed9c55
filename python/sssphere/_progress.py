"""Progress bars (tqdm) driven by the fraction done, as the renderers and the learning
pipeline report it."""

from __future__ import annotations

import sys

from tqdm import tqdm


class Progress:
    """A tqdm bar on stderr for work that reports the fraction done (0 to 1).

    Called with the fraction, it returns True, so it can be a render's ``progress``
    callback. On a terminal it redraws up to ten times a second; in a log file it writes a
    line every 10 s. ``enabled=False`` shows nothing. The bar is drawn at the first
    fraction reported, so that work refused before it starts (a bad output path, an option
    that does not fit the scene) shows an error, not an empty bar above it.
    """

    def __init__(self, label: str, enabled: bool = True):
        self._label, self._enabled = label, enabled
        self._bar: tqdm | None = None

    def update(self, fraction: float, text: str = "") -> None:
        fraction = min(max(float(fraction), 0.0), 1.0)
        if self._bar is None:
            tty = sys.stderr.isatty()
            self._bar = tqdm(total=1.0, desc=self._label, disable=not self._enabled,
                             file=sys.stderr, mininterval=0.1 if tty else 10.0,
                             dynamic_ncols=True, bar_format="{desc}: {percentage:5.1f}%|{bar}| "
                                                            "{elapsed}<{remaining}{postfix}")
        if text:
            self._bar.set_postfix_str(text, refresh=False)
        self._bar.update(fraction - self._bar.n)

    def __call__(self, fraction: float) -> bool:
        self.update(fraction)
        return True

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
