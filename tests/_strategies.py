"""What the property tests' strategies share.

Hypothesis runs the *simplest* example first: every draw at its least value (a target at
the window's centre, no squint, no motion, the first placement of each list). A CI test
of one or two examples therefore ran that one scene, the same in every test, and the
domain's edges only in the slow tier. Drawn first in a strategy, :data:`NOT_THE_SIMPLEST`
rejects that example (its draw is ``False`` there and ``True`` in every other), before
anything is simulated: the few examples CI runs are then drawn across the domain (the
same ones on every run, ``derandomize``; new ones with ``--hypothesis-profile=fresh``).
"""

from __future__ import annotations

from hypothesis import strategies as st

NOT_THE_SIMPLEST = st.booleans().filter(bool)


def beyond_the_simplest(strategy):
    """``strategy`` with :data:`NOT_THE_SIMPLEST` drawn before it: for a test's ``@given``
    of plain strategies, one argument wrapped rejects the simplest example."""
    return st.tuples(NOT_THE_SIMPLEST, strategy).map(lambda drawn: drawn[1])
