"""Figures (matplotlib, Agg-safe): raw amplitude and phase, focused image in dB (peak-
normalised, −50…0 dB, grey), IRF cuts, seed-style cut comparisons of two simulators,
motion fits against their truth."""

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


def image_db(image, path=None, *, title="Focused image", dynamic_range=50.0, zoom=None,
             aspect="auto"):
    """Peak-normalised image in dB (−dynamic_range … 0, grey), axes in metres.

    Args:
        image: :class:`~sarjax.Image`.
        path: PNG path (optional).
        zoom: optional ((x_min, x_max), (r_min, r_max)) window [m].
        aspect: ``"auto"`` (fill the figure) or ``"equal"`` (a metre is a metre on both
            axes).
    """
    plt = _plt()
    data = np.abs(np.asarray(image.data))
    az, rg = np.asarray(image.azimuth), np.asarray(image.range)
    if zoom is not None:
        (x0, x1), (r0, r1) = zoom
        ia = (az >= x0) & (az <= x1)
        ir = (rg >= r0) & (rg <= r1)
        if not (ia.any() and ir.any()):
            raise ValueError(f"zoom={zoom} m holds no pixel of the image (azimuth "
                             f"{az[0]:.6g} … {az[-1]:.6g} m, range {rg[0]:.6g} … {rg[-1]:.6g} m)")
        data, az, rg = data[ia][:, ir], az[ia], rg[ir]
    db = 20 * np.log10(np.maximum(data / data.max(), 10 ** (-dynamic_range / 20)))
    fig, ax = plt.subplots(figsize=(6, 5))
    im = ax.imshow(db, aspect=aspect, origin="lower", cmap="gray", vmin=-dynamic_range, vmax=0,
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


def raw_amplitude_phase(raw, path=None, *, title="Raw data"):
    """|h(x', r')| and arg h(x', r') of :class:`~sarjax.RawData` side by side (grey,
    phase in [−π, π]); save to ``path`` when given."""
    plt = _plt()
    data = np.asarray(raw.data)
    az, rg = np.asarray(raw.azimuth), np.asarray(raw.range)
    extent = [rg[0], rg[-1], az[0], az[-1]]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    im0 = axes[0].imshow(np.abs(data), aspect="auto", origin="lower", cmap="gray",
                         extent=extent)
    im1 = axes[1].imshow(np.angle(data), aspect="auto", origin="lower", cmap="gray",
                         extent=extent, vmin=-np.pi, vmax=np.pi, interpolation="nearest")
    fig.colorbar(im0, ax=axes[0], label="amplitude")
    fig.colorbar(im1, ax=axes[1], label="phase [rad]")
    axes[0].set_ylabel("azimuth x' [m]")
    for ax, what in zip(axes, ("amplitude", "phase"), strict=True):
        ax.set_xlabel("range r' [m]")
        ax.set_title(f"{title}: {what}")
    return _finish(fig, path)


def compare_cuts(first, second, labels=("reference", "test"), *, azimuth=None, range=None,
                 path=None, title=""):
    """Seed-style comparison of two simulators: amplitude and phase of raw data along an
    azimuth cut (fixed r') and a range cut (fixed x'), with the phase difference.

    Args:
        first, second: :class:`~sarjax.RawData` on the same grid (e.g. ``time_domain``
            and ``small_deviation``).
        labels: legend labels.
        azimuth: x' of the range cut [m] (default: the middle pulse).
        range: r' of the azimuth cut [m] (default: the brightest range sample).
    """
    plt = _plt()
    a, b = np.asarray(first.data), np.asarray(second.data)
    if a.shape != b.shape:
        raise ValueError(f"raw data shapes differ: {a.shape} and {b.shape}")
    az, rg = np.asarray(first.azimuth), np.asarray(first.range)
    i = a.shape[0] // 2 if azimuth is None else int(np.argmin(np.abs(az - azimuth)))
    j = (int(np.argmax(np.sum(np.abs(a) ** 2, axis=0))) if range is None
         else int(np.argmin(np.abs(rg - range))))
    fig, axes = plt.subplots(3, 2, figsize=(11, 7.5), sharex="col")
    for col, (axis, ca, cb, name, where) in enumerate((
            (az, a[:, j], b[:, j], "azimuth x' [m]", f"r' = {rg[j]:.1f} m"),
            (rg, a[i, :], b[i, :], "range r' [m]", f"x' = {az[i]:.2f} m"))):
        axes[0, col].plot(axis, np.abs(ca), label=labels[0])
        axes[0, col].plot(axis, np.abs(cb), "--", label=labels[1])
        axes[0, col].set_title(f"{'azimuth' if col == 0 else 'range'} cut at {where} {title}")
        axes[1, col].plot(axis, np.angle(ca), label=labels[0])
        axes[1, col].plot(axis, np.angle(cb), "--", label=labels[1])
        weight = np.abs(ca) > 1e-3 * max(np.abs(ca).max(), 1e-300)
        diff = np.where(weight, np.angle(cb * np.conj(ca)), np.nan)
        axes[2, col].plot(axis, diff, color="k")
        axes[2, col].set_xlabel(name)
    axes[0, 0].set_ylabel("amplitude")
    axes[1, 0].set_ylabel("phase [rad]")
    axes[2, 0].set_ylabel(f"phase {labels[1]} − {labels[0]} [rad]")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    axes[0, 0].legend()
    return _finish(fig, path)


def motion_fit(azimuth, fitted, truth=None, path=None, *, title="Motion fit"):
    """Fitted trajectory deviations [cm] and pointing jitter [mrad] with their truth.

    Args:
        azimuth: (azimuth,) pulse positions x' [m].
        fitted: the estimated :class:`~sarjax.Motion`.
        truth: the true :class:`~sarjax.Motion` (optional).
    """
    plt = _plt()
    azimuth = np.asarray(azimuth)
    n = len(azimuth)
    fit = [np.asarray(v) for v in fitted.resolve(n)]
    ref = None if truth is None else [np.asarray(v) for v in truth.resolve(n)]
    fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
    for ax, k, name, scale, unit in ((axes[0], 0, "horizontal Δy", 100, "cm"),
                                     (axes[1], 1, "vertical Δz", 100, "cm"),
                                     (axes[2], 2, "pointing δ_az", 1e3, "mrad")):
        if ref is not None:
            ax.plot(azimuth, scale * ref[k], color="0.6", lw=3, label="truth")
        ax.plot(azimuth, scale * fit[k], color="k", lw=1, label="fit")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
    axes[0].legend()
    axes[0].set_title(title)
    axes[2].set_xlabel("azimuth x' [m]")
    return _finish(fig, path)


def validity_map(dataset, path=None, *, title="Validity map", limit_db=-25.0):
    """A campaign's raw NMSE against the exact model [dB] over the deviation rms [m]: one
    panel per method, one line per squint (median over the realizations); runs that
    warned are marked with crosses, silent ones with dots; the dashed line is the
    fidelity a valid run must reach (``limit_db``). ``dataset``: a
    :func:`sarjax.campaign.load` store."""
    plt = _plt()
    method = np.array([str(m) for m in np.asarray(dataset["method"].values)])
    rms = np.asarray(dataset["deviation_rms"].values, float)
    squint = np.asarray(dataset["squint_deg"].values, float)
    nmse = np.asarray(dataset["nmse_db"].values, float)
    warned = np.asarray(dataset["warned"].values)
    methods = list(dict.fromkeys(method))
    fig, axes = plt.subplots(1, len(methods), figsize=(4.2 * len(methods), 3.4),
                             sharey=True, squeeze=False)
    # a deviation of 0 sits at the left edge of the log axis
    positive = rms[rms > 0]
    floor = positive.min() / 3 if positive.size else 1e-3
    shown = np.where(rms > 0, rms, floor)
    for ax, m in zip(axes[0], methods, strict=True):
        for phi in sorted(set(squint)):
            sel = (method == m) & (squint == phi) & np.isfinite(nmse)
            if not np.any(sel):
                continue
            grid = sorted(set(shown[sel]))
            median = [np.median(nmse[sel & (shown == g)]) for g in grid]
            (line,) = ax.plot(grid, median, label=f"squint {phi:g}°")
            for flag, marker in ((1, "x"), (0, "o")):
                pick = sel & (warned == flag)
                ax.plot(shown[pick], nmse[pick], marker, ms=4, color=line.get_color(),
                        alpha=0.6)
        ax.axhline(limit_db, ls="--", color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set(title=m, xlabel="deviation rms [m] (left edge: none)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("raw NMSE vs exact [dB]")
    axes[0][0].legend(fontsize=8, title="× warned, ● silent", title_fontsize=8)
    fig.suptitle(title)
    return _finish(fig, path)


def fit_monte_carlo(dataset, path=None, *, title="Motion fits against the Cramér–Rao bound"):
    """A fit campaign's line-of-sight errors against the bound: one panel per deviation rms,
    the empirical distribution (CDF) of error / CRB per SNR over the realizations done,
    fits that did not converge marked with crosses at their ratio; the dashed line is an
    efficient estimator's ratio (1). ``dataset``: a :func:`sarjax.campaign.load` store of
    a :class:`sarjax.campaign.FitMonteCarlo`."""
    plt = _plt()
    rms = np.asarray(dataset["deviation_rms"].values, float)
    snr = np.asarray(dataset["snr_db"].values, float)
    error = np.asarray(dataset["error_los"].values, float)
    bound = np.asarray(dataset["crb_los"].values, float)
    converged = np.asarray(dataset["converged"].values)
    amplitudes = sorted(set(rms))
    fig, axes = plt.subplots(1, len(amplitudes), figsize=(4.2 * len(amplitudes), 3.4),
                             sharey=True, squeeze=False)
    for ax, r in zip(axes[0], amplitudes, strict=True):
        for q in sorted(set(snr[rms == r])):
            sel = (rms == r) & (snr == q) & (converged >= 0) & np.isfinite(error / bound)
            if not np.any(sel):
                continue
            ratio = np.sort(error[sel] / bound[sel])
            share = np.arange(1, ratio.size + 1) / ratio.size
            (line,) = ax.step(ratio, share, where="post",
                              label=f"{q:g} dB ({ratio.size} fits)")
            failed = sel & (converged == 0)
            ax.plot(error[failed] / bound[failed],
                    np.interp(error[failed] / bound[failed], ratio, share), "x",
                    color=line.get_color())
        ax.axvline(1.0, ls="--", color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set(title=f"deviation rms {r * 100:g} cm", xlabel="LOS error / CRB")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("share of fits ≤ ratio")
    axes[0][0].legend(fontsize=8, title="SNR (× not converged)", title_fontsize=8)
    fig.suptitle(title)
    return _finish(fig, path)


def _finish(fig, path):
    if path is not None:
        fig.savefig(path, dpi=110, bbox_inches="tight")
        _plt().close(fig)
        return path
    return fig
