"""The golden image set (issue 31): float images of every model — 1D TF, 2D TF over (value,
gradient magnitude), bivariate fields — under three cameras, rendered by the CLI from fixed
inputs committed in python/tests/golden/. Recorded before the split of reconstruction and TF
integration, so a restructuring of the library is checked image by image (test_golden_images.py,
max |Δ| ≤ 1e−6 on every channel).

    python3 python/tests/golden.py inputs   # (re)write the inputs (model, second field, TFs)
    python3 python/tests/golden.py record   # (re)write golden/images.npz with the current build
    python3 python/tests/golden.py record uniform,gaussian  # only those models' images

Recording replaces the reference: do it only on purpose, and say why in the commit message."""
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
GOLDEN = HERE / "golden"
IMAGES = GOLDEN / "images.npz"
SIZE = "20x16"  # width × height; non-square, so x/y swaps show

# Models per TF kind. gmm-mc draws 6 realizations (seeded, deterministic); `members` reads the
# ensemble itself. The 2D and bivariate lists are the models with 2D / bivariate kernels.
MODELS_1D = ["mean", "uniform", "uniform-fast", "uniform-exact", "gaussian", "gmm-ordered", "gmm-mc",
             "quantile-range", "quantile-mean", "quantile-mean-mass", "iqr", "quartile-lower",
             "quartile-middle", "quartile-upper", "members"]
MODELS_2D = ["mean", "uniform", "uniform-fast", "uniform-exact", "gaussian", "gaussian-exact",
             "quantile-range", "quantile-mean",
             "quantile-mean-mass", "iqr", "quartile-lower", "quartile-middle", "quartile-upper"]
MODELS_BIVARIATE = ["mean", "uniform", "uniform-fast", "uniform-exact", "gaussian", "gmm-ordered",
                    "quantile-range", "quantile-mean", "quantile-mean-mass", "iqr",
                    "quartile-lower", "quartile-middle", "quartile-upper"]

# SPEC §5's camera (the whole box, as a TF file gives), the framing camera (the voxels the TF
# makes visible) turned and raised, and an orthographic view along +x.
CAMERAS = {
    "box": [],
    "framed": ["--frame", "visible", "--azimuth", "40", "--elevation", "-15", "--zoom", "1.3"],
    "parallel": ["--view", "+x", "--parallel-scale", "9"],
}


def binary():
    if os.environ.get("UDVR_BINARY"):
        return os.environ["UDVR_BINARY"]
    build = pathlib.Path(os.environ.get("UDVR_BUILD_DIR", HERE.parents[1] / "build"))
    if not build.is_absolute():
        build = HERE.parents[1] / build
    return str(build / "udvr")


def udvr(*args):
    cmd = [binary()] + [str(a) for a in args]
    env = dict(os.environ, UDVR_NO_PROGRESS="1")
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env,
                       stdin=subprocess.DEVNULL)
    if p.returncode != 0:
        raise RuntimeError("%s failed (%d): %s" % (" ".join(cmd), p.returncode, p.stderr))
    return p.stdout


def cases():
    """(key, udvr render arguments without the output) for every golden image."""
    g = GOLDEN
    out = []
    for cam, cargs in CAMERAS.items():
        for m in MODELS_1D:
            src = g / "ensemble.nc" if m == "members" else g / "model.vti"
            extra = ["--realizations", "6"] if m == "gmm-mc" else []
            out.append(("1d/%s/%s" % (cam, m),
                        [src, "--model", m, "--tf", g / "tf.json", *extra, *cargs]))
        for m in MODELS_2D:
            out.append(("2d/%s/%s" % (cam, m),
                        [g / "model.vti", "--model", m, "--tf2", g / "tf2.json", *cargs]))
        for m in MODELS_BIVARIATE:
            out.append(("bivariate/%s/%s" % (cam, m),
                        [g / "model.vti", "--second", g / "second.vti", "--model", m, "--tf2",
                         g / "tf2_bivariate.json", *cargs]))
    return out


def render(args, tmp):
    npy = pathlib.Path(tmp) / "img.npy"
    udvr("render", *args, "--size", SIZE, "--threads", "2", "--float", npy, "-o",
         pathlib.Path(tmp) / "img.png")
    return np.load(npy)


def write_inputs():
    """A 16³ tangle ensemble (12 members, bimodal noise) and its model (q = 8, K = 3); a 16³
    spheres ensemble's model as the second field; a 1D TF with a step and a flat zero stretch;
    the widget 2D TF of data/tf2/tangle.json; a bivariate widget TF over (tangle, spheres)."""
    GOLDEN.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        t = pathlib.Path(tmp)
        udvr("generate", "tangle", "--dims", "16", "-o", t / "tangle.vti")
        udvr("perturb", t / "tangle.vti", "--members", "12", "--noise", "bimodal", "--seed", "3",
             "-o", GOLDEN / "ensemble.nc")
        udvr("build", GOLDEN / "ensemble.nc", "--quantiles", "8", "--gmm", "3", "-o",
             GOLDEN / "model.vti")
    # The second field: the spheres' noisy members placed on the tangle's grid (bivariate
    # fields share one grid), built through the Python module like a user's own arrays.
    import udvr as udvr_module
    grid = json.loads(udvr("info", GOLDEN / "model.vti", "--json"))["grid"]
    members = udvr_module.perturb(udvr_module.generate("spheres", [16, 16, 16]), members=12,
                                  noise="gaussian", seed=4)
    ensemble = udvr_module.Ensemble(np.asarray(members.values), grid["origin"], grid["spacing"])
    with tempfile.TemporaryDirectory() as tmp:
        nc = pathlib.Path(tmp) / "spheres.nc"
        udvr_module.write_ensemble(str(nc), ensemble)
        udvr("build", nc, "--quantiles", "8", "--gmm", "3", "-o", GOLDEN / "second.vti")
    info1 = json.loads(udvr("info", GOLDEN / "model.vti", "--json"))
    info2 = json.loads(udvr("info", GOLDEN / "second.vti", "--json"))

    def value_range(info):
        pct = info["values"]["percentiles"]  # of the voxel means
        return float(pct["1"]), float(pct["99"])

    lo, hi = value_range(info1)
    lo2, hi2 = value_range(info2)
    span = hi - lo
    tf = [{
        "Name": "golden",
        "RGBPoints": [lo, 0.23, 0.30, 0.75, lo + 0.5 * span, 0.87, 0.87, 0.87,
                      lo + 0.5 * span, 0.9, 0.5, 0.1, hi, 0.70, 0.02, 0.15],
        "Points": [lo, 0.0, 0.5, 0.0, lo + 0.35 * span, 0.0, 0.5, 0.0, lo + 0.45 * span, 0.6, 0.5,
                   0.0, lo + 0.7 * span, 0.2, 0.5, 0.0, lo + 0.7 * span, 0.8, 0.5, 0.0, hi, 0.4,
                   0.5, 0.0],
    }]
    (GOLDEN / "tf.json").write_text(json.dumps(tf, indent=1) + "\n")
    tf2 = json.loads((HERE.parents[1] / "data" / "tf2" / "tangle.json").read_text())
    tf2["resolution"] = [128, 96]
    (GOLDEN / "tf2.json").write_text(json.dumps(tf2, indent=1) + "\n")
    s2 = hi2 - lo2
    biv = {
        "name": "golden-bivariate",
        "domain": [lo, hi, lo2, hi2],
        "resolution": [96, 80],
        "widgets": [
            {"type": "box", "x": [lo + 0.4 * span, lo + 0.6 * span],
             "y": [lo2 + 0.3 * s2, lo2 + 0.8 * s2], "rgba": [0.2, 0.5, 0.9, 0.5]},
            {"type": "ellipse", "center": [lo + 0.25 * span, lo2 + 0.5 * s2],
             "sigma": [0.08 * span, 0.2 * s2], "angle": 30, "rgba": [0.9, 0.3, 0.1, 0.8]},
            {"type": "band", "points": [[lo + 0.1 * span, lo2 + 0.1 * s2],
                                        [lo + 0.5 * span, lo2 + 0.6 * s2],
                                        [lo + 0.9 * span, lo2 + 0.4 * s2]],
             "half_width": [0.04 * span, 0.05 * s2], "rgba": [0.1, 0.8, 0.3, 0.6]},
        ],
    }
    (GOLDEN / "tf2_bivariate.json").write_text(json.dumps(biv, indent=1) + "\n")


def render_all(models=None):
    """{key: image} for every case (of `models` only, if given), two renders at a time (each on
    two threads)."""
    from concurrent.futures import ThreadPoolExecutor

    def one(case):
        with tempfile.TemporaryDirectory() as tmp:
            return case[0], render(case[1], tmp)

    todo = [c for c in cases() if models is None or c[0].split("/")[-1] in models]
    with ThreadPoolExecutor(2) as pool:
        return dict(pool.map(one, todo))


def record(models=None):
    """Every image, or those of `models` (the others kept from golden/images.npz)."""
    images = {} if models is None else dict(np.load(IMAGES))
    keys = {c[0] for c in cases()}
    images = {k: v for k, v in images.items() if k in keys}
    fresh = render_all(models)
    for key, image in fresh.items():
        print(key, "max alpha %.3f" % image[..., 3].max())
    images.update(fresh)
    np.savez_compressed(IMAGES, **images)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else ""
    if what == "inputs":
        write_inputs()
    elif what == "record":
        record(set(sys.argv[2].split(",")) if len(sys.argv) > 2 else None)
    else:
        sys.exit(__doc__)
