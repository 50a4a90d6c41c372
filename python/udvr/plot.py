"""matplotlib figures of udvr's results: the TF, the distribution at a probed point under the TF
(the paper's Fig. 2), panels of rendered images with their RMSEs (the experiments' layout) and
RMSE curves (Fig. 5a). Drawing only: every number comes from the compiled core."""
import numpy as np


def _axes(ax, **subplots):
    import matplotlib.pyplot as plt
    if ax is not None:
        return ax.figure, ax
    return plt.subplots(**subplots)


def _tf_strip(tf, ax, lo, hi):
    """The TF's colour as a strip with its opacity curve over it, on [lo, hi]."""
    x = np.linspace(lo, hi, 512)
    rgba = tf(x)
    ax.imshow(rgba[None, :, :3], extent=(lo, hi, 0, 1), aspect="auto", origin="lower")
    ax.plot(x, rgba[:, 3], color="black", lw=1.5)
    ax.set_xlim(lo, hi)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("value")
    ax.set_ylabel("opacity")


def transfer_function(tf, ax=None, range=None):  # noqa: A002  (matplotlib's word)
    """Colour strip and opacity curve of a 1D TF over its control points (or `range`)."""
    fig, ax = _axes(ax, figsize=(6, 1.8))
    lo, hi = tf.domain() if range is None else range
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    _tf_strip(tf, ax, lo, hi)
    ax.set_title("transfer function")
    return fig


def distribution(model, point=None, model_name="quantile-range", tf=None, *, world=None,
                 ax=None, **probe_options):
    """The PDF of `model_name` at a point (index, or world=) above the TF over the same values,
    as the paper's Fig. 2 and `udvr probe --plot`: the continuous density from the probed CDF,
    point masses as spikes, the expected (E[αr], E[αg], E[αb], E[α]) in the title.
    ax: two axes (pdf, tf) to draw into; returns the figure."""
    from . import _probe_full
    result, dist, tf = _probe_full(model, point, model_name, tf, world=world, **probe_options)
    if ax is None:
        import matplotlib.pyplot as plt
        fig, (ax_pdf, ax_tf) = plt.subplots(2, 1, figsize=(6, 4), sharex=True,
                                            gridspec_kw={"height_ratios": [2, 1]})
    else:
        ax_pdf, ax_tf = ax
        fig = ax_pdf.figure
    lo, hi = dist["lo"], dist["hi"]
    x, cdf = dist["cdf_x"], dist["cdf_y"]
    if len(x) > 1 and dist["continuous_mass"] > 0:
        dens = np.diff(cdf) / np.diff(x)  # the CDF's slope per sample interval: the density
        mid = 0.5 * (x[1:] + x[:-1])
        ax_pdf.fill_between(mid, dens, color="tab:blue", alpha=0.35, lw=0)
        ax_pdf.plot(mid, dens, color="tab:blue", lw=1.5, label="density")
    atoms, mass = dist["atoms"], dist["atom_mass"]
    if len(atoms):
        top = ax_pdf.get_ylim()[1] if len(x) > 1 and dist["continuous_mass"] > 0 else 1.0
        ax_pdf.vlines(atoms, 0, top * mass / mass.max(), color="tab:red", lw=2,
                      label="point mass")
    ax_pdf.set_ylabel("density")
    e = result["expected_rgba"]
    p = result["point"]
    ax_pdf.set_title(f"{result['model']} at ({p[0]:g}, {p[1]:g}, {p[2]:g}): "
                     f"E[a] = {e[3]:.4f}")
    _tf_strip(tf, ax_tf, lo, hi)
    return fig


def panel(images, labels=None, *, truth=None, ncols=None, title=None, size=2.6):
    """Images side by side (the experiments' figure layout): a list of (H, W, 3|4) arrays, or a
    dict label → image; with `truth`, each label gets its RMSE (SPEC §6) against it."""
    import matplotlib.pyplot as plt
    if isinstance(images, dict):
        labels = list(images) if labels is None else labels
        images = list(images.values())
    images = list(images)
    labels = [""] * len(images) if labels is None else list(labels)
    if len(labels) != len(images):
        raise ValueError(f"{len(images)} images but {len(labels)} labels")
    if truth is not None:
        from . import rmse
        labels = [f"{lab}\nRMSE {rmse(im, truth):.4f}" if im is not truth else lab
                  for im, lab in zip(images, labels)]
    n = len(images)
    ncols = ncols or min(n, 4)
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(size * ncols, size * nrows + 0.4),
                             squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, im, lab in zip(axes.ravel(), images, labels):
        ax.imshow(np.clip(np.asarray(im)[..., :3], 0, 1))
        ax.set_title(lab, fontsize=9)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def rmse_curve(table, x="q", *, by=("model", "density"), ax=None, title=None):
    """RMSE against `x` (q, or "members") for each group of rows (the paper's Fig. 5a): `table`
    as udvr.experiment returns it (DataFrame or list of dicts). Rows without an x (models
    without quantiles) are drawn as horizontal lines."""
    rows = table.to_dict("records") if hasattr(table, "to_dict") else list(table)
    by = (by,) if isinstance(by, str) else tuple(by)
    groups = {}
    for r in rows:
        if r.get("model") == "ground-truth":
            continue
        key = " ".join(str(r[k]) for k in by if r.get(k) not in (None, ""))
        groups.setdefault(key, []).append(r)
    fig, ax = _axes(ax, figsize=(6, 4))
    for i, (key, rs) in enumerate(sorted(groups.items())):
        pts = sorted((r[x], r["rmse"]) for r in rs if r.get(x))
        if len(pts) > 1 or (pts and len(pts) == len(rs)):
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=key,
                    color=f"C{i % 10}")
        else:
            ax.axhline(float(np.mean([r["rmse"] for r in rs])), ls="--", lw=1, label=key,
                       color=f"C{i % 10}")
    ax.set_xlabel(x)
    ax.set_ylabel("RMSE")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    return fig


__all__ = ["transfer_function", "distribution", "panel", "rmse_curve"]
