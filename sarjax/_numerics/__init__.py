"""Numerics shared by the simulators and the processors: phasors by multiply-adds and
windowed-sinc, exponential-of-semicircle and linear interpolation (imports nothing else
from sarjax)."""
