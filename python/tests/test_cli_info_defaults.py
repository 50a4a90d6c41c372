"""`udvr info`, the default transfer function, the framing camera and `probe --world` (issue 11).

References are independent of the C++ code: numpy.percentile and numpy moments for `info`, the
preset's documented construction for the default TF, and NumPy trilinear interpolation for
`probe` on a plain field. Grids are tiny, so the file runs in a few seconds.
"""
import json
import pathlib
import re

import numpy as np
import pytest

from conftest import assert_one_line_error, run_ok, run_udvr, write_nrrd

pytestmark = pytest.mark.usefixtures("udvr_binary")


@pytest.fixture(scope="module")
def field(tmp_path_factory):
    """An 11×9×7 float field with a skewed distribution, origin and spacing set."""
    d = tmp_path_factory.mktemp("info")
    rng = np.random.default_rng(5)
    values = rng.gamma(2.0, 3.0, size=(7, 9, 11)).astype(np.float32)  # (z, y, x)
    values[3, 4, 5] = 100.0  # an outlier the robust range leaves out
    path = write_nrrd(d / "f.nrrd", [float(v) for v in values.ravel()], (11, 9, 7),
                      header_extra=("spacings: 0.5 2 1", "space origin: (1,-2,3)"))
    return d, path, values


def test_info_json_matches_numpy(field):
    d, path, values = field
    j = json.loads(run_ok("info", path, "--json").stdout)
    assert j["kind"] == "field"
    assert j["type"] == "float32"
    assert j["grid"]["dims"] == [11, 9, 7]
    assert j["grid"]["spacing"] == [0.5, 2, 1]
    assert j["grid"]["bounds"] == pytest.approx([1, 6, -2, 14, 3, 9])
    v = j["values"]
    flat = values.ravel().astype(np.float64)
    assert v["count"] == flat.size
    assert v["min"] == pytest.approx(flat.min())
    assert v["max"] == pytest.approx(flat.max())
    assert v["mean"] == pytest.approx(flat.mean(), rel=1e-12)
    assert v["stddev"] == pytest.approx(flat.std(), rel=1e-9)
    for p, x in v["percentiles"].items():
        assert x == pytest.approx(np.percentile(flat, float(p)), rel=1e-12, abs=1e-12), p


def test_info_of_ensemble_and_model(pipeline):
    e = json.loads(run_ok("info", pipeline.ensemble, "--json").stdout)
    assert e["kind"] == "ensemble" and e["members"] == 5
    assert e["arrays"][0]["dims"][0] == "member"
    m = json.loads(run_ok("info", pipeline.model, pipeline.model_q6, "--json").stdout)
    assert [x["kind"] for x in m] == ["model", "model"]
    assert m[0]["model"]["quantiles"] == 8 and m[0]["model"]["gmm_components"] == 2
    assert m[1]["model"]["quantiles"] == 6 and m[1]["model"]["gmm_components"] == 0
    assert m[0]["model"]["samples_per_voxel"] == 5
    names = [a["name"] for a in m[0]["arrays"]]
    assert {"mean", "stddev", "quantiles", "gmm"} <= set(names)
    text = run_ok("info", pipeline.model).stdout
    assert "q = 8 quantiles, GMM K = 2" in text and "percentiles" in text


def test_info_histogram_png_and_bad_flags(field, tmp_path):
    _, path, _ = field
    out = tmp_path / "h.png"
    r = run_ok("info", path, "--histogram", out, "--log", "--tf", "viridis", "--bins", "32")
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert "preset 'viridis'" in r.stderr
    assert_one_line_error(run_udvr("info", path, "--histogram", tmp_path / "h.jpg"), "png")
    assert_one_line_error(run_udvr("info", path, "--log"), "--histogram")
    assert_one_line_error(run_udvr("info", path, path, "--histogram", out), "one input")
    assert_one_line_error(run_udvr("info", path, "--histogram", out, "--bins", "0"), "bins")
    assert_one_line_error(run_udvr("info", tmp_path / "missing.nrrd"), "missing.nrrd")


def boundary_opacity(values, spacing, lo, hi, bins=64, points=16):
    """The default TF's opacity (docs/rendering.md, "The default TF"), independently in NumPy:
    mean gradient magnitude per value bin over [lo, hi] (np.gradient: central differences,
    one-sided at the faces), smoothed over 3 bins (bins with < max(1, 1e-5 n) points left out),
    less the median gradient magnitude, times the face weight clip(2 - r, 0, 1), r the bin's
    share of face points over the volume's; relative to its peak, less 0.2, over 0.8, times
    0.5 (clipped to [0, 0.5]); at 16 even points."""
    v = values.astype(np.float64)
    gz, gy, gx = np.gradient(v, spacing[2], spacing[1], spacing[0])
    g = np.sqrt(gx * gx + gy * gy + gz * gz).astype(np.float32).astype(np.float64)
    w = (hi - lo) / bins
    b = (v - lo) / w
    inside = (b >= 0) & (b < bins)
    idx = b[inside].astype(int)
    count = np.bincount(idx, minlength=bins).astype(float)
    total = np.bincount(idx, weights=g[inside], minlength=bins)
    onface = np.zeros(v.shape, bool)
    onface[0], onface[-1], onface[:, 0], onface[:, -1] = True, True, True, True
    onface[:, :, 0], onface[:, :, -1] = True, True
    face = np.bincount(idx, weights=onface[inside].astype(float), minlength=bins)
    ok = count >= max(1.0, 1e-5 * v.size)
    mean = np.zeros(bins)
    for k in range(bins):
        sel = [o for o in range(max(0, k - 1), min(bins, k + 2)) if ok[o]]
        c = sum(count[o] for o in sel)
        mean[k] = sum(total[o] for o in sel) / c if c > 0 else 0.0
    floor = np.sort(g.ravel())[g.size // 2]
    share = face.sum() / count.sum()
    keep = np.where(ok, np.clip(2.0 - np.divide(face, count, where=ok, out=np.zeros(bins)) / share,
                                0.0, 1.0), 1.0)
    weight = np.maximum(0.0, mean - floor) * keep
    xs = lo + (hi - lo) * np.arange(points) / (points - 1)
    pos = np.clip((xs - lo) / w - 0.5, 0.0, bins - 1.0)
    b0 = pos.astype(int)
    b1 = np.minimum(b0 + 1, bins - 1)
    m = weight[b0] * (1 - (pos - b0)) + weight[b1] * (pos - b0)
    return list(xs), list(0.5 * np.clip((m / weight.max() - 0.2) / 0.8, 0.0, 1.0))


def test_default_tf_is_the_preset_over_the_robust_range(field, tmp_path):
    _, path, values = field
    tf_path = tmp_path / "tf.json"
    img_default = tmp_path / "a.npy"
    r = run_ok("render", path, "--size", "24x20", "--save-tf", tf_path, "--float", img_default,
               "-o", tmp_path / "a.png")
    assert "no --tf: the preset 'cool-to-warm'" in r.stderr
    tf = json.loads(tf_path.read_text())[0]
    flat = values.ravel().astype(np.float64)
    lo, hi, median = np.percentile(flat, [0.5, 99.5, 50])
    rgb = tf["RGBPoints"]
    assert rgb[0] == pytest.approx(lo, rel=1e-6) and rgb[-4] == pytest.approx(hi, rel=1e-6)
    assert rgb[1:4] == pytest.approx([0.231373, 0.298039, 0.752941])  # cool-to-warm's blue
    pts = tf["Points"]  # x, alpha, midpoint, sharpness
    x_ref, a_ref = boundary_opacity(values, (0.5, 2.0, 1.0), lo, hi)
    assert pts[0::4] == pytest.approx(x_ref, rel=1e-6, abs=1e-9)
    assert pts[1::4] == pytest.approx(a_ref, abs=2e-4)
    assert 0.05 < max(pts[1::4]) <= 0.5
    # The saved TF renders the same image when given back: the camera does not depend on it.
    img_saved = tmp_path / "b.npy"
    run_ok("render", path, "--size", "24x20", "--tf", tf_path,
           "--float", img_saved, "-o", tmp_path / "b.png")
    assert np.array_equal(np.load(img_default), np.load(img_saved))
    # --tf-range spreads the preset over the given range.
    run_ok("render", path, "--size", "8x8", "--tf", "grayscale", "--tf-range", "2,30",
           "--save-tf", tf_path, "-o", tmp_path / "c.png")
    tf = json.loads(tf_path.read_text())[0]
    assert tf["RGBPoints"][0] == 2 and tf["RGBPoints"][4] == 30


def test_info_histogram_draws_the_tf_render_uses(field, pipeline, tmp_path):
    """`info --histogram` draws (and --save-tf writes) the TF `render` uses by default: the
    boundary-emphasis opacity, not the median ramp, for a field, a model and an ensemble."""
    _, path, values = field
    info_tf, render_tf = tmp_path / "info.json", tmp_path / "render.json"
    r = run_ok("info", path, "--histogram", tmp_path / "h.png", "--save-tf", info_tf)
    assert "opacity on boundaries" in r.stderr
    run_ok("render", path, "--size", "8x8", "--save-tf", render_tf, "-o", tmp_path / "r.png")
    assert json.loads(info_tf.read_text()) == json.loads(render_tf.read_text())
    lo, hi = np.percentile(values.ravel().astype(np.float64), [0.5, 99.5])
    _, a_ref = boundary_opacity(values, (0.5, 2.0, 1.0), lo, hi)
    assert json.loads(info_tf.read_text())[0]["Points"][1::4] == pytest.approx(a_ref, abs=2e-4)
    # A model's means, and an ensemble (render --model members: over the member means).
    for source, flags in ((pipeline.model, ()), (pipeline.ensemble, ("--model", "members"))):
        run_ok("info", source, "--histogram", tmp_path / "h.png", "--save-tf", info_tf)
        run_ok("render", source, *flags, "--size", "8x8", "--save-tf", render_tf,
               "-o", tmp_path / "r.png")
        assert json.loads(info_tf.read_text()) == json.loads(render_tf.read_text()), source


def test_tf_flag_errors(field, tmp_path):
    _, path, _ = field
    out = tmp_path / "x.png"
    assert_one_line_error(run_udvr("render", path, "--tf", "jet", "-o", out), "jet", "presets")
    assert_one_line_error(run_udvr("render", path, "--tf-range", "5,1", "-o", out), "--tf-range")
    assert_one_line_error(run_udvr("render", path, "--save-tf", tmp_path / "t.txt", "-o", out),
                          "--save-tf")
    assert not out.exists()


def camera_of(stderr):
    m = re.search(r"camera pos (\S+) (\S+) (\S+)  focal (\S+) (\S+) (\S+)  up (\S+) (\S+) (\S+)",
                  stderr)
    v = [float(x) for x in m.groups()]
    return np.array(v[0:3]), np.array(v[3:6]), np.array(v[6:9])


def test_axis_views_and_framing(field, tmp_path):
    _, path, _ = field
    out = tmp_path / "v.png"
    pos, focal, up = camera_of(run_ok("render", path, "--view", "+x", "--size", "8",
                                      "-o", out).stderr)
    look = focal - pos
    assert look / np.linalg.norm(look) == pytest.approx([1, 0, 0], abs=1e-9)
    assert up == pytest.approx([0, 0, 1], abs=1e-9)
    pos, focal, up = camera_of(run_ok("render", path, "--view", "-z", "--size", "8",
                                      "-o", out).stderr)
    assert (focal - pos) / np.linalg.norm(focal - pos) == pytest.approx([0, 0, -1], abs=1e-9)
    assert up == pytest.approx([0, 1, 0], abs=1e-9)
    # --zoom 2 halves the distance of the same framed camera.
    p1, f1, _ = camera_of(run_ok("render", path, "--view", "+y", "--size", "8", "-o", out).stderr)
    p2, f2, _ = camera_of(run_ok("render", path, "--view", "+y", "--zoom", "2", "--size", "8",
                                 "-o", out).stderr)
    assert np.linalg.norm(p2 - f2) == pytest.approx(np.linalg.norm(p1 - f1) / 2, rel=1e-5)
    assert_one_line_error(run_udvr("render", path, "--view", "up", "-o", out), "--view")
    assert_one_line_error(run_udvr("render", path, "--frame", "all", "-o", out), "--frame")
    assert_one_line_error(run_udvr("render", path, "--view", "+x", "--position", "1,2,3",
                                   "-o", out), "--position")


def test_a_huge_step_count_asks_for_force(field, tmp_path):
    _, path, _ = field
    out = tmp_path / "s.png"
    r = run_udvr("render", path, "--step", "1e-7", "--size", "64", "-o", out)
    assert_one_line_error(r, "--force", "samples")
    assert not out.exists()
    run_ok("render", path, "--step", "0.25", "--size", "8", "-o", out)


def trilinear(values, p):
    """values (z, y, x); p = (i, j, k) index coordinates inside the grid."""
    i, j, k = p
    i0, j0, k0 = int(np.floor(i)), int(np.floor(j)), int(np.floor(k))
    fx, fy, fz = i - i0, j - j0, k - k0
    out = 0.0
    for dz, wz in ((0, 1 - fz), (1, fz)):
        for dy, wy in ((0, 1 - fy), (1, fy)):
            for dx, wx in ((0, 1 - fx), (1, fx)):
                if wx * wy * wz:
                    out += wx * wy * wz * float(values[k0 + dz, j0 + dy, i0 + dx])
    return out


def test_probe_takes_plain_fields_and_world_points(field):
    _, path, values = field
    by_index = json.loads(run_ok("probe", path, "--point", "4.25,3.5,2.75", "--model", "mean",
                                 "--json").stdout)
    assert by_index["value"] == pytest.approx(trilinear(values, (4.25, 3.5, 2.75)), rel=1e-6)
    # world = origin + index × spacing: (1 + 4.25·0.5, −2 + 3.5·2, 3 + 2.75·1)
    by_world = json.loads(run_ok("probe", path, "--world", "3.125,5,5.75", "--model", "mean",
                                 "--json").stdout)
    assert by_world["value"] == pytest.approx(by_index["value"], rel=1e-12)
    assert by_world["world"] == pytest.approx([3.125, 5, 5.75])
    assert by_world["grid_dims"] == [11, 9, 7]
    text = run_ok("probe", path, "--point", "1,1,1", "--model", "mean").stdout
    assert "of the input's 11x9x7 grid" in text and "world (1.5, 0, 4)" in text
    assert_one_line_error(run_udvr("probe", path, "--model", "mean"), "--point", "--world")
    assert_one_line_error(run_udvr("probe", path, "--point", "1,1,1", "--world", "1,1,1",
                                   "--model", "mean"), "--point")


def test_review_cases_of_a_new_user(field, pipeline, tmp_path):
    _, path, _ = field
    # info: an ensemble variable picked with --var is still an ensemble.
    name = json.loads(run_ok("info", pipeline.ensemble, "--json").stdout)["variable"]
    j = json.loads(run_ok("info", pipeline.ensemble, "--var", name, "--json").stdout)
    assert j["kind"] == "ensemble" and j["members"] == 5
    # info: a file that is not a volume, and histogram flags without --histogram.
    assert_one_line_error(run_udvr("info", pipeline.tf), "unknown field format")
    for flags in (["--bins", "8"], ["--save-tf", tmp_path / "t.json"], ["--tf-range", "0,1"]):
        assert_one_line_error(run_udvr("info", path, *flags), "--histogram")
    # render: --save-tf naming a folder fails before any image is written.
    folder = tmp_path / "dir.json"
    folder.mkdir()
    out = tmp_path / "r.png"
    assert_one_line_error(run_udvr("render", path, "--save-tf", folder, "-o", out), "directory")
    assert not out.exists()
    # render: a TF that shows nothing says so; a huge image asks for --force; "x" is "+x".
    r = run_ok("render", path, "--tf-range", "1000,2000", "--size", "8", "-o", out)
    assert "udvr: warning: the TF gives no voxel" in r.stderr
    r = run_ok("render", path, "--tf-range", "1000,2000", "--size", "8", "--frame", "visible",
               "-o", out)
    assert "udvr: warning: the TF gives no voxel" in r.stderr
    assert "nothing is visible" in r.stderr
    assert_one_line_error(run_udvr("render", path, "--size", "10000x10000", "-o", out), "--force")
    run_ok("render", path, "--view", "x", "--size", "8", "-o", out)
    # probe: --model defaults to mean; 1D TF flags with --tf2 are refused.
    j = json.loads(run_ok("probe", path, "--point", "1,1,1", "--json").stdout)
    assert j["model"] == "mean"
    tf2 = pathlib.Path(__file__).resolve().parents[2] / "data" / "tf2" / "tangle.json"
    assert_one_line_error(run_udvr("probe", path, "--point", "1,1,1", "--tf2", tf2, "--save-tf",
                                   tmp_path / "s.json"), "--tf2")
    # build: one field without --downsample points to it.
    assert_one_line_error(run_udvr("build", path, "-o", tmp_path / "m.vti"), "--downsample")
