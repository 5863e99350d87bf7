"""Numerics shared by the simulators and the processors: phasors by multiply-adds and
windowed-sinc / linear interpolation (imports nothing else from sarjax)."""
