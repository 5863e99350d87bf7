"""Physical constants (SI units)."""

SPEED_OF_LIGHT = 299_792_458.0  # c [m/s], exact (SI definition)
