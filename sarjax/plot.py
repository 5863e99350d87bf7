"""Figures (matplotlib, Agg-safe): raw amplitude, focused image in dB, IRF cuts."""

from __future__ import annotations

import numpy as np

from .metrics import upsample_fft


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def raw_amplitude(raw, path=None, *, title="Raw amplitude"):
    """Plot |h(x', r')| of :class:`~sarjax.RawData`; save to ``path`` when given."""
    plt = _plt()
    data = np.abs(np.asarray(raw.data))
    az, rg = np.asarray(raw.azimuth), np.asarray(raw.range)
    fig, ax = plt.subplots(figsize=(6, 5))
    im = ax.imshow(data, aspect="auto", origin="lower", cmap="gray",
                   extent=[rg[0], rg[-1], az[0], az[-1]])
    ax.set_xlabel("range r' [m]")
    ax.set_ylabel("azimuth x' [m]")
    ax.set_title(title)
    fig.colorbar(im, ax=ax, label="amplitude")
    return _finish(fig, path)


def image_db(image, path=None, *, title="Focused image", dynamic_range=50.0, zoom=None):
    """Peak-normalised image in dB (−dynamic_range … 0, grey).

    Args:
        image: :class:`~sarjax.Image`.
        path: PNG path (optional).
        zoom: optional ((x_min, x_max), (r_min, r_max)) window [m].
    """
    plt = _plt()
    data = np.abs(np.asarray(image.data))
    az, rg = np.asarray(image.azimuth), np.asarray(image.range)
    if zoom is not None:
        (x0, x1), (r0, r1) = zoom
        ia = (az >= x0) & (az <= x1)
        ir = (rg >= r0) & (rg <= r1)
        data, az, rg = data[ia][:, ir], az[ia], rg[ir]
    db = 20 * np.log10(np.maximum(data / data.max(), 10 ** (-dynamic_range / 20)))
    fig, ax = plt.subplots(figsize=(6, 5))
    im = ax.imshow(db, aspect="auto", origin="lower", cmap="gray", vmin=-dynamic_range, vmax=0,
                   extent=[rg[0], rg[-1], az[0], az[-1]])
    ax.set_xlabel("slant range r [m]")
    ax.set_ylabel("azimuth x [m]")
    ax.set_title(title)
    fig.colorbar(im, ax=ax, label="dB")
    return _finish(fig, path)


def cuts(images, labels, *, azimuth, range, path=None, half_width=(8.0, 40.0), title=""):
    """Azimuth and range cuts (dB, normalised to the first image's peak) through a target.

    Args:
        images: sequence of :class:`~sarjax.Image`.
        labels: legend labels.
        azimuth, range: target position [m].
        half_width: (azimuth, range) half-widths of the plotted cuts [m].
    """
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ref = None
    for img, label in zip(images, labels, strict=True):
        data = np.abs(np.asarray(img.data))
        az, rg = np.asarray(img.azimuth), np.asarray(img.range)
        i = int(np.argmin(np.abs(az - azimuth)))
        j = int(np.argmin(np.abs(rg - range)))
        ii = slice(max(i - 4, 0), i + 5)
        jj = slice(max(j - 4, 0), j + 5)
        sub = data[ii, jj]
        di, dj = np.unravel_index(np.argmax(sub), sub.shape)
        i, j = ii.start + di, jj.start + dj
        ref = 1.02 * data[i, j] if ref is None else ref  # ≈ upsampled peak
        complex_data = np.asarray(img.data)
        floor = 1e-6
        for ax, line, axis, centre, hw in (
            (axes[0], complex_data[:, j], az, az[i], half_width[0]),
            (axes[1], complex_data[i, :], rg, rg[j], half_width[1]),
        ):
            # band-limited 8× upsampling of a 128-sample stretch (sampled cuts mislead)
            k = int(np.argmin(np.abs(axis - centre)))
            lo, hi = max(k - 64, 0), min(k + 64, len(axis))
            fine = np.abs(upsample_fft(line[lo:hi], 8))
            step = axis[1] - axis[0]
            fine_axis = axis[lo] + np.arange(fine.size) * step / 8
            sel = np.abs(fine_axis - centre) <= hw
            ax.plot(fine_axis[sel], 20 * np.log10(np.maximum(fine[sel] / ref, floor)), label=label)
    axes[0].set_xlabel("azimuth x [m]")
    axes[1].set_xlabel("slant range r [m]")
    for ax in axes:
        ax.set_ylabel("dB")
        ax.set_ylim(-60, 3)
        ax.grid(alpha=0.3)
        ax.legend()
    axes[0].set_title(f"azimuth cut {title}")
    axes[1].set_title(f"range cut {title}")
    return _finish(fig, path)


def motion_profile(azimuth, motion, path=None):
    """Trajectory deviations [cm] and pointing error [mrad] against pulse position."""
    plt = _plt()
    n = len(azimuth)
    dy, dz, daz = (np.asarray(v) for v in motion.resolve(n))
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    axes[0].plot(azimuth, 100 * dy, label="horizontal Δy")
    axes[0].plot(azimuth, 100 * dz, label="vertical Δz")
    axes[0].set_ylabel("deviation [cm]")
    axes[0].legend()
    axes[1].plot(azimuth, 1e3 * daz)
    axes[1].set_ylabel("pointing δ_az [mrad]")
    axes[1].set_xlabel("azimuth x' [m]")
    for ax in axes:
        ax.grid(alpha=0.3)
    return _finish(fig, path)


def _finish(fig, path):
    if path is not None:
        fig.savefig(path, dpi=110, bbox_inches="tight")
        _plt().close(fig)
        return path
    return fig
