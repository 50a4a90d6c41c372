"""Fair by construction (issue 35): the default camera does not depend on where the TF came from
(preset, file, saved with --save-tf); a model and its ground truth rendered with defaults get the
same camera and TF (a downsampled model records its full-resolution field's default TF); `render`
records its settings as PNG text, and `compare` refuses images made with different TFs, cameras
or sizes (--force: a warning and the RMSE)."""
import json

import numpy as np
import pytest

from conftest import assert_one_line_error, run_ok, run_udvr

udvr = pytest.importorskip("udvr")
pytestmark = pytest.mark.usefixtures("udvr_binary")


def settings(path):
    return udvr.read_png_text(str(path))


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    t = tmp_path_factory.mktemp("fair")
    # A field whose brick means span a narrower range than its values (as a CT's do).
    rng = np.random.default_rng(35)
    f = udvr.generate("tangle", [24, 24, 24])
    noisy = udvr.Field((f.values + rng.normal(0, 2.0, f.values.shape)).astype(np.float32),
                       [0, 0, 0], [1, 1, 1])
    udvr.write_field(str(t / "field.vti"), noisy)
    run_ok("build", t / "field.vti", "--downsample", "4", "--gmm", "0", "-o", t / "model.vti")
    return t


def test_render_records_its_settings(data):
    t = data
    run_ok("render", t / "field.vti", "--size", "40x30", "-o", t / "a.png")
    s = settings(t / "a.png")
    assert s["udvr:model"] == "mean" and s["udvr:size"] == "40x30"
    assert s["udvr:source"].endswith("field.vti")
    tf = json.loads(s["udvr:tf"])[0]
    lo, hi = map(float, s["udvr:tf-range"].split(","))
    assert tf["RGBPoints"][0] == pytest.approx(lo) and tf["RGBPoints"][-4] == pytest.approx(hi)
    v = udvr.load(str(t / "field.vti")).mean
    assert [lo, hi] == pytest.approx(np.percentile(v, [0.5, 99.5]), rel=1e-6)
    assert s["udvr:camera"].startswith("position ")


def test_the_default_camera_does_not_depend_on_the_tf_source(data):
    t = data
    args = ["--size", "40x30"]
    run_ok("render", t / "field.vti", *args, "--save-tf", t / "tf.json", "--float",
           t / "p.npy", "-o", t / "preset.png")
    run_ok("render", t / "field.vti", *args, "--tf", t / "tf.json", "--float", t / "f.npy", "-o",
           t / "file.png")
    run_ok("render", t / "field.vti", *args, "--tf", "viridis", "-o", t / "named.png")
    cams = {settings(t / p)["udvr:camera"] for p in ("preset.png", "file.png", "named.png")}
    assert len(cams) == 1
    # The saved TF is the preset: the same image.
    assert np.abs(np.load(t / "p.npy") - np.load(t / "f.npy")).max() <= 1e-6
    # With defaults it is SPEC §5's camera: azimuth 30, elevation 20 about +y from +z.
    run_ok("render", t / "field.vti", *args, "--azimuth", "30", "--elevation", "20", "-o",
           t / "spec.png")
    assert settings(t / "spec.png")["udvr:camera"] in cams


def test_a_model_and_its_truth_get_the_same_camera_and_tf(data):
    t = data
    run_ok("render", t / "field.vti", "--size", "48", "-o", t / "truth.png")
    run_ok("render", t / "model.vti", "--model", "quantile-range", "--size", "48", "-o",
           t / "model.png")
    a, b = settings(t / "model.png"), settings(t / "truth.png")
    for key in ("udvr:tf", "udvr:tf-range", "udvr:camera", "udvr:size"):
        assert a[key] == b[key], key
    # The model's own means span less than the field (the noise averages out in 4³ bricks).
    m = udvr.load(str(t / "model.vti"))
    assert np.percentile(m.mean, 99.5) < 0.9 * np.percentile(
        udvr.load(str(t / "field.vti")).mean, 99.5)
    r = run_ok("compare", t / "model.png", t / "truth.png")
    assert 0 < float(r.stdout) < 0.2 and "warning" not in r.stderr
    # Python's render picks the same default TF for the model and the field.
    img_m = udvr.render(m, "quantile-range", None, 24)
    tf_m = udvr.TransferFunction.preset_for("cool-to-warm", m)
    tf_f = udvr.TransferFunction.preset_for("cool-to-warm", udvr.load(str(t / "field.vti")))
    assert tf_m.to_json() == tf_f.to_json() and img_m.shape == (24, 24, 4)


def test_an_ensemble_model_and_its_members_get_the_same_tf(tmp_path):
    e = udvr.perturb(udvr.generate("tangle", [16, 16, 16]), members=6, seed=2)
    udvr.write_ensemble(str(tmp_path / "e.nc"), e)
    run_ok("build", tmp_path / "e.nc", "--gmm", "0", "-o", tmp_path / "m.vti")
    run_ok("render", tmp_path / "m.vti", "--model", "quantile-range", "--size", "32", "-o",
           tmp_path / "m.png")
    run_ok("render", tmp_path / "e.nc", "--model", "members", "--size", "32", "-o",
           tmp_path / "e.png")
    a, b = settings(tmp_path / "m.png"), settings(tmp_path / "e.png")
    assert a["udvr:tf"] == b["udvr:tf"] and a["udvr:camera"] == b["udvr:camera"]


def test_compare_refuses_images_made_differently(data):
    t = data
    run_ok("render", t / "field.vti", "--size", "48", "-o", t / "truth.png")
    cases = [(["--tf", "viridis"], "transfer functions"),
             (["--tf-range", "-5,5"], "TF range"),
             (["--frame", "visible"], "cameras"),
             (["--azimuth", "60"], "cameras")]
    for extra, mention in cases:
        run_ok("render", t / "field.vti", "--size", "48", *extra, "-o", t / "other.png")
        r = run_udvr("compare", t / "other.png", t / "truth.png")
        assert_one_line_error(r, mention, "--force")
        assert r.stdout == ""
        r = run_ok("compare", t / "other.png", t / "truth.png", "--force")
        assert "compare: warning:" in r.stderr and mention in r.stderr
        assert float(r.stdout) > 0
    run_ok("render", t / "field.vti", "--size", "40x48", "-o", t / "other.png")
    assert_one_line_error(run_udvr("compare", t / "other.png", t / "truth.png"), "sizes")


def test_the_default_tf_finds_an_object_in_noisy_air(tmp_path):
    # CT-like: air at 100 with noise (not zero), a holder plate at 300 touching the faces, and a
    # sphere at 800 in the middle. The old default (opacity from the median up) made the noisy
    # air above the median an opaque fog; the boundary rule leaves air clear and shows the sphere.
    rng = np.random.default_rng(35)
    n = 40
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32)
    v = 100 + 10 * rng.normal(size=(n, n, n))
    v[z < 4] = 300 + 10 * rng.normal(size=v[z < 4].shape)
    r = np.sqrt((x - 20) ** 2 + (y - 20) ** 2 + (z - 20) ** 2)
    v = np.where(r < 9, 800 + 10 * rng.normal(size=v.shape), v).astype(np.float32)
    udvr.write_field(str(tmp_path / "ct.vti"), udvr.Field(v))
    run_ok("render", tmp_path / "ct.vti", "--size", "64", "--save-tf", tmp_path / "tf.json",
           "--float", tmp_path / "a.npy", "-o", tmp_path / "a.png")
    tf = json.loads((tmp_path / "tf.json").read_text())[0]
    xs, alphas = np.array(tf["Points"][0::4]), np.array(tf["Points"][1::4])
    # A hard-edged sphere: its own values carry the boundary's gradient (no partial volume).
    assert np.interp(100.0, xs, alphas) < 0.05  # the air: a tenth of the peak at most
    assert np.interp(300.0, xs, alphas) < 0.05  # the plate touches the faces: clear
    assert np.interp(800.0, xs, alphas) > 0.3
    a = np.load(tmp_path / "a.npy")[..., 3]
    assert a[32, 32] > 0.9  # the ray through the sphere's centre
    # Everything visible is the sphere: within 14 px of the image centre (its radius projects
    # to ~10 px with SPEC 5's camera at 64 px).
    rows, cols = np.nonzero(a > 0.3)
    assert len(rows) > 50 and np.hypot(rows - 31.5, cols - 31.5).max() < 14
    # The old rule's TF (a ramp from the median over the robust range) also shows the plate and
    # the air's upper half: twice the visible pixels or more.
    run_ok("render", tmp_path / "ct.vti", "--size", "64", "--tf-range",
           ",".join(map(str, np.percentile(v, [0.5, 99.5]))), "--float", tmp_path / "b.npy",
           "-o", tmp_path / "b.png")
    assert (np.load(tmp_path / "b.npy")[..., 3] > 0.3).sum() > 2 * len(rows)
