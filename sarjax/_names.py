"""Messages for names a user got wrong: the valid ones and the closest match."""

from __future__ import annotations

import difflib


def unknown_names(what: str, given, known) -> str:
    """``"unknown {what} ['nmu_pulses'] (did you mean 'num_pulses'?); known: [...]"``.

    Args:
        what: the kind of name, e.g. ``"[scene] entries"``.
        given: the unknown names (any iterable of str).
        known: every valid name.
    """
    given, known = sorted(given), sorted(known)
    hints = []
    for name in given:
        close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
        if close:
            hints.append(f"{close[0]!r}" + (f" for {name!r}" if len(given) > 1 else ""))
    hint = f" (did you mean {', '.join(hints)}?)" if hints else ""
    return f"unknown {what} {given}{hint}; known: {known}"
