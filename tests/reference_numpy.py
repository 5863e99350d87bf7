"""Naive float64 NumPy reference for the time-domain SAR raw-data model.

This is a deliberately slow, loop-based transcription of the point-target
echo model (seed 000, eqs. 19-20), written independently of ``sarjax`` so it
can serve as a test oracle.  Keep the problem sizes small: it is an explicit
triple loop over pulses, range samples and scatterers.

Model
-----
* ``c = 299792458`` m/s, ``lambda = c / f``, range-coordinate chirp rate
  ``b = 4*pi*bandwidth / (c**2 * tau)`` [rad/m^2].
* Pulse ``p`` at along-track ``x'_p = azimuth_center + (p - (N_x-1)/2) * v/PRF``;
  range sample ``k`` at ``r'_k = near_range + k * c / (2 f_s)``.
* Actual antenna phase centre at ``(x'_p, dy_p, H + dz_p)`` (``dy`` horizontal
  cross-track, positive towards the scene; ``dz`` vertical, positive up).
* Scatterer ``(x, r, h, gamma)`` at ``(x, y_P, h)`` with
  ``y_P = sqrt(r**2 - (H - h)**2)``.
* ``R = |antenna - scatterer|`` (exact 3-D distance).
* ``dr_xr = sqrt((y_P - dy)**2 + (H + dz - h)**2) - r``,
  pointing offset ``dx = (r + dr_xr) * daz_p``.
* Footprint ``X = lambda * r / L``; two-way pattern ``sinc(u)**2`` with
  ``u = (x' - x - dx) / X``.
* ``h(x', r') = sum gamma * exp(-j 4 pi R / lambda - j b (r' - R)**2)
  * rect * sinc(u)**2`` with ``rect = 1`` iff ``|r' - R| < c tau / 4``.

Extensions (seed 002, seed 004), all off by default:

* squint ``phi_d``: ``u = (a + r T - (r + dr_xr) daz) L / (lambda r) / (1 - a T / r)``
  with ``a = x' - x``, ``T = tan(phi_d)``, i.e. ``u = -(L/lambda) tan(phi - phi_d)``
  for the look angle ``tan(phi) = (x - x') / r`` when ``daz = 0``.
* moving scatterers: at time ``t`` (antenna at ``x' = v t``) the scatterer is at
  azimuth ``x + v_a (t - x/v)`` and at nominal slant range ``rho = r + v_r (t - x/v)``
  along its look direction: ``(y_P rho / r, H - (H - h) rho / r)``.
* non-stop-and-go: ``R`` is replaced by ``c tau_d / 2`` where ``tau_d`` solves
  ``c tau_d = |A(t) - P(t)| + |A(t + tau_d) - P(t + tau_d)|`` (seed 004 eq. 3),
  iterated to convergence; the pattern is evaluated at ``t + tau_d / 2``.
"""

from __future__ import annotations

import math

import numpy as np

SPEED_OF_LIGHT = 299792458.0


def azimuth_axis(num_pulses, prf, velocity, azimuth_center=0.0):
    """Along-track antenna positions x'_p [m] (float64)."""
    dx = float(velocity) / float(prf)
    centre = 0.5 * (num_pulses - 1)
    return np.array(
        [float(azimuth_center) + (p - centre) * dx for p in range(num_pulses)],
        dtype=np.float64,
    )


def range_axis(num_range, near_range, sampling_rate):
    """Slant-range sample positions r'_k [m] (float64)."""
    dr = SPEED_OF_LIGHT / (2.0 * float(sampling_rate))
    return np.array(
        [float(near_range) + k * dr for k in range(num_range)], dtype=np.float64
    )


def simulate_reference(
    *,
    carrier_frequency,
    bandwidth,
    chirp_duration,
    sampling_rate,
    prf,
    velocity,
    height,
    antenna_length,
    target_azimuth,
    target_range,
    target_reflectivity,
    target_height=None,
    horizontal=None,
    vertical=None,
    pointing=None,
    num_pulses,
    num_range,
    near_range,
    azimuth_center=0.0,
    squint=0.0,
    target_velocity_range=None,
    target_velocity_azimuth=None,
    stop_and_go=True,
):
    """Return ``(data, x_axis, r_axis)``; ``data`` has shape (num_pulses, num_range).

    ``horizontal``/``vertical``/``pointing`` are per-pulse arrays (length
    ``num_pulses``) or ``None`` for zero deviation.
    """
    if squint != 0.0 or target_velocity_range is not None or (
        target_velocity_azimuth is not None
    ) or not stop_and_go:
        return _simulate_extended(
            carrier_frequency=carrier_frequency, bandwidth=bandwidth,
            chirp_duration=chirp_duration, sampling_rate=sampling_rate, prf=prf,
            velocity=velocity, height=height, antenna_length=antenna_length,
            target_azimuth=target_azimuth, target_range=target_range,
            target_reflectivity=target_reflectivity, target_height=target_height,
            horizontal=horizontal, vertical=vertical, pointing=pointing,
            num_pulses=num_pulses, num_range=num_range, near_range=near_range,
            azimuth_center=azimuth_center, squint=squint,
            target_velocity_range=target_velocity_range,
            target_velocity_azimuth=target_velocity_azimuth, stop_and_go=stop_and_go,
        )
    c = SPEED_OF_LIGHT
    f = float(carrier_frequency)
    wavelength = c / f
    tau = float(chirp_duration)
    b = 4.0 * math.pi * float(bandwidth) / (c * c * tau)
    half_len = c * tau / 4.0
    H = float(height)
    L = float(antenna_length)

    xs = np.asarray(target_azimuth, dtype=np.float64).ravel()
    rs = np.asarray(target_range, dtype=np.float64).ravel()
    gs = np.asarray(target_reflectivity, dtype=np.complex128).ravel()
    if target_height is None:
        hs = np.zeros_like(xs)
    else:
        hs = np.broadcast_to(
            np.asarray(target_height, dtype=np.float64), xs.shape
        ).copy()
    n_t = xs.shape[0]
    assert rs.shape == (n_t,) and gs.shape == (n_t,)

    def per_pulse(arr):
        if arr is None:
            return np.zeros(num_pulses, dtype=np.float64)
        out = np.asarray(arr, dtype=np.float64).ravel()
        assert out.shape == (num_pulses,)
        return out

    dys = per_pulse(horizontal)
    dzs = per_pulse(vertical)
    dazs = per_pulse(pointing)

    x_axis = azimuth_axis(num_pulses, prf, velocity, azimuth_center)
    r_axis = range_axis(num_range, near_range, sampling_rate)

    data = np.zeros((num_pulses, num_range), dtype=np.complex128)
    for p in range(num_pulses):
        xp = float(x_axis[p])
        dy = float(dys[p])
        dz = float(dzs[p])
        daz = float(dazs[p])
        for k in range(num_range):
            rp = float(r_axis[k])
            acc = 0.0 + 0.0j
            for i in range(n_t):
                x = float(xs[i])
                r = float(rs[i])
                h = float(hs[i])
                gamma = complex(gs[i])
                y_p = math.sqrt(r * r - (H - h) ** 2)
                # exact 3-D distance from the actual antenna phase centre
                ex = xp - x
                ey = dy - y_p
                ez = (H + dz) - h
                R = math.sqrt(ex * ex + ey * ey + ez * ez)
                if not abs(rp - R) < half_len:
                    continue
                # antenna pattern, with the pointing offset
                dr_xr = math.sqrt((y_p - dy) ** 2 + (H + dz - h) ** 2) - r
                dx_point = (r + dr_xr) * daz
                footprint = wavelength * r / L
                u = (xp - x - dx_point) / footprint
                w2 = float(np.sinc(u)) ** 2
                phase = -4.0 * math.pi * R / wavelength - b * (rp - R) ** 2
                acc += gamma * complex(math.cos(phase), math.sin(phase)) * w2
            data[p, k] = acc
    return data, x_axis, r_axis


def _simulate_extended(
    *, carrier_frequency, bandwidth, chirp_duration, sampling_rate, prf, velocity,
    height, antenna_length, target_azimuth, target_range, target_reflectivity,
    target_height, horizontal, vertical, pointing, num_pulses, num_range, near_range,
    azimuth_center, squint, target_velocity_range, target_velocity_azimuth, stop_and_go,
):
    """The model with squint, moving scatterers and the non-stop-and-go delay."""
    c = SPEED_OF_LIGHT
    wavelength = c / float(carrier_frequency)
    tau = float(chirp_duration)
    b = 4.0 * math.pi * float(bandwidth) / (c * c * tau)
    half_len = c * tau / 4.0
    H = float(height)
    L = float(antenna_length)
    v = float(velocity)
    T = math.tan(float(squint))

    xs = np.asarray(target_azimuth, dtype=np.float64).ravel()
    n_t = xs.shape[0]
    rs = np.asarray(target_range, dtype=np.float64).ravel()
    gs = np.asarray(target_reflectivity, dtype=np.complex128).ravel()

    def per_target(arr):
        if arr is None:
            return np.zeros(n_t)
        return np.broadcast_to(np.asarray(arr, dtype=np.float64), (n_t,)).copy()

    hs = per_target(target_height)
    vrs = per_target(target_velocity_range)
    vas = per_target(target_velocity_azimuth)

    def per_pulse(arr):
        if arr is None:
            return np.zeros(num_pulses)
        return np.asarray(arr, dtype=np.float64).ravel()

    dys, dzs, dazs = per_pulse(horizontal), per_pulse(vertical), per_pulse(pointing)
    x_axis = azimuth_axis(num_pulses, prf, velocity, azimuth_center)
    r_axis = range_axis(num_range, near_range, sampling_rate)

    data = np.zeros((num_pulses, num_range), dtype=np.complex128)
    for p in range(num_pulses):
        t0 = float(x_axis[p]) / v  # transmit time
        dy, dz, daz = float(dys[p]), float(dzs[p]), float(dazs[p])

        def antenna(t):
            return (v * t, dy, H + dz)

        for i in range(n_t):
            x, r, h = float(xs[i]), float(rs[i]), float(hs[i])
            vr, va = float(vrs[i]), float(vas[i])
            y_p = math.sqrt(r * r - (H - h) ** 2)

            def target(t):
                since = t - x / v
                rho = r + vr * since
                return (x + va * since, y_p * rho / r, H - (H - h) * rho / r), rho

            def distance(t):
                a = antenna(t)
                q, _ = target(t)
                return math.sqrt(sum((a[j] - q[j]) ** 2 for j in range(3)))

            r_tx = distance(t0)
            if stop_and_go:
                echo = r_tx
                t_pattern = t0
            else:
                delay = 2.0 * r_tx / c
                for _ in range(100):
                    new = (r_tx + distance(t0 + delay)) / c
                    if new == delay:
                        break
                    delay = new
                echo = 0.5 * c * delay
                t_pattern = t0 + 0.5 * delay
            a_pos = antenna(t_pattern)
            q_pos, rho = target(t_pattern)
            along = a_pos[0] - q_pos[0]
            dr_xr = math.sqrt((q_pos[1] - dy) ** 2 + (a_pos[2] - q_pos[2]) ** 2) - rho
            u = ((along + rho * T - (rho + dr_xr) * daz) * L / (wavelength * rho)
                 / (1.0 - along * T / rho))
            w2 = float(np.sinc(u)) ** 2
            gamma = complex(gs[i])
            for k in range(num_range):
                rp = float(r_axis[k])
                if not abs(rp - echo) < half_len:
                    continue
                phase = -4.0 * math.pi * echo / wavelength - b * (rp - echo) ** 2
                data[p, k] += gamma * complex(math.cos(phase), math.sin(phase)) * w2
    return data, x_axis, r_axis
