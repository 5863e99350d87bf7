"""Raw-data simulators (physics.md §3–10)."""

from ._base import AbstractSimulator as AbstractSimulator
from ._time_domain import TimeDomain as TimeDomain
