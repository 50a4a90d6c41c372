"""The notebook API (issue 14, point 2) against the CLI: build, probe and render from NumPy and
xarray give what `udvr build/probe/render` give for the same inputs (bit for bit where the code
path is the same), the model's arrays are views of its memory, and the GIL is released."""
import json
import threading
import time

import numpy as np
import pytest

from conftest import run_ok, write_tf

udvr = pytest.importorskip("udvr")
xr = pytest.importorskip("xarray")

ARRAYS = ("mean", "stddev", "min", "max", "quantiles", "iqr", "gmm")
PROBE_MODELS = ("mean", "uniform", "gaussian", "gmm-ordered", "quantile-range", "quantile-mean",
                "iqr", "quartile-upper")


def assert_same_model(a, b):
    for name in ARRAYS:
        va, vb = getattr(a, name), getattr(b, name)
        assert (va is None) == (vb is None), name
        if va is not None:
            np.testing.assert_array_equal(va, vb, err_msg=name)
    for key in ("quantile_count", "gmm_components", "samples_per_voxel", "downsample", "bounds",
                "full_res_min_spacing", "density"):
        assert getattr(a, key) == getattr(b, key), key
    assert a.grid.dims == b.grid.dims
    np.testing.assert_allclose(a.grid.origin, b.grid.origin, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.grid.spacing, b.grid.spacing, rtol=1e-12)


def as_dataarray(values, grid, member=True):
    coords = {n: grid.origin[a] + grid.spacing[a] * np.arange(grid.dims[a])
              for a, n in enumerate("xyz")}
    dims = (("member",) if member else ()) + ("z", "y", "x")
    return xr.DataArray(values, dims=dims, coords=coords, name="value")


@pytest.fixture(scope="module")
def ens(pipeline):
    """The CLI's 5-member ensemble (perturb --seed 3) as udvr reads it."""
    return udvr.read_ensemble([str(pipeline.ensemble)])


# ---- build ---------------------------------------------------------------------------------------

def test_build_from_numpy_xarray_and_path_equals_cli_build(pipeline, ens):
    cli = udvr.load(pipeline.model)  # udvr build ensemble.nc --gmm 2
    g = ens.grid
    with pytest.warns(UserWarning, match="quantile boundaries interpolate"):
        from_numpy = udvr.build(ens.values, gmm=2, origin=g.origin, spacing=g.spacing)
    assert_same_model(from_numpy, cli)
    # Shuffled dims are put back in (member, z, y, x) order by name.
    da = as_dataarray(ens.values, g).transpose("x", "member", "z", "y")
    with pytest.warns(UserWarning):
        assert_same_model(udvr.build(da, gmm=2), cli)
    with pytest.warns(UserWarning):
        assert_same_model(udvr.build(str(pipeline.ensemble), gmm=2), cli)


def test_build_kde_and_bricks_equal_cli(pipeline, tmp_path, ens):
    out = tmp_path / "kde.vti"
    run_ok("build", pipeline.ensemble, "--density", "kde", "--bandwidth", "scott", "--gmm", "0",
           "--quantiles", "4", "-o", out)
    g = ens.grid
    kde = udvr.build(ens.values, quantiles=4, gmm=0, density="kde", bandwidth="scott",
                     origin=g.origin, spacing=g.spacing)
    assert_same_model(kde, udvr.load(out))
    assert kde.bandwidth == udvr.load(out).bandwidth > 0

    # A 16³ field in 3³ bricks: 5 points per axis, one trailing plane left out, as the CLI says.
    out = tmp_path / "bricks.vti"
    r = run_ok("build", pipeline.field, "--downsample", "3", "--gmm", "3", "-o", out)
    assert "left out the trailing 1,1,1 planes" in r.stderr
    f = udvr.read_field(str(pipeline.field))
    with pytest.warns(UserWarning, match="left out the trailing 1,1,1 planes"):
        bricks = udvr.build(as_dataarray(f.values, f.grid, member=False), gmm=3, downsample=3)
    assert_same_model(bricks, udvr.load(out))
    assert bricks.grid.dims == [5, 5, 5] and bricks.downsample == 3


def test_any_real_dtype_is_converted(ens):
    ints = np.round(ens.values * 100).astype(np.int16)
    a = udvr.build(ints, quantiles=4, gmm=0, progress=None)
    b = udvr.build(ints.astype(np.float64), quantiles=4, gmm=0, progress=None)
    np.testing.assert_array_equal(a.quantiles, b.quantiles)
    np.testing.assert_array_equal(a.mean, b.mean)


def test_progress_callback_reaches_the_total(ens):
    calls = []
    udvr.build(ens.values, quantiles=4, gmm=2, progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1] == (16**3, 16**3)
    assert all(d <= t for d, t in calls)


# ---- views, xarray, files ---------------------------------------------------------------------

def test_model_arrays_are_read_only_views_of_its_memory(pipeline):
    m = udvr.load(pipeline.model)
    for name in ARRAYS:
        a, b = getattr(m, name), getattr(m, name)
        assert a.__array_interface__["data"][0] == b.__array_interface__["data"][0], name
        assert not a.flags.writeable and not a.flags.owndata, name
    copy = m.array("quantiles")  # the copying accessor reads the same numbers elsewhere
    assert copy.__array_interface__["data"][0] != m.quantiles.__array_interface__["data"][0]
    np.testing.assert_array_equal(copy, m.quantiles)
    ds = m.to_xarray()
    for name in ARRAYS:
        assert np.shares_memory(ds[name].values, getattr(m, name)), name
    view, expected = m.gmm, m.array("gmm")
    del m, ds  # the view keeps the model alive
    np.testing.assert_array_equal(view, expected)


def test_xarray_and_file_round_trips(pipeline, tmp_path):
    m = udvr.load(pipeline.model)
    ds = m.to_xarray()
    assert set(ds.data_vars) == set(ARRAYS)
    assert ds["quantiles"].dims == ("z", "y", "x", "quantile_boundary")
    np.testing.assert_allclose(ds["x"].values, m.grid.origin[0] + m.grid.spacing[0] * np.arange(16))
    assert ds.attrs["quantile_count"] == 8 and ds.attrs["samples_per_voxel"] == 5
    assert_same_model(udvr.Model.from_xarray(ds), m)
    m.save(tmp_path / "again.vti")
    assert_same_model(udvr.load(tmp_path / "again.vti"), m)
    # A plain field loads as a mean-only model, as render/probe read it.
    f = udvr.load(pipeline.field)
    assert f.quantiles is None and f.mean.shape == (16, 16, 16)


# ---- probe -----------------------------------------------------------------------------------

def cli_probe(pipeline, *args):
    return json.loads(run_ok("probe", pipeline.model, *args, "--json").stdout)


def test_probe_equals_probe_json(pipeline):
    m = udvr.load(pipeline.model)
    tf = udvr.TransferFunction.from_paraview(pipeline.tf)
    for name in PROBE_MODELS:
        cli = cli_probe(pipeline, "--point", "3.25,7.5,10.125", "--model", name,
                        "--tf", pipeline.tf)
        assert m.probe((3.25, 7.5, 10.125), model=name, tf=tf) == cli, name
    # A world point, and the default preset over the model's means.
    cli = cli_probe(pipeline, "--world", "0.1,-1.2,0.7", "--model", "gaussian")
    assert m.probe(world=(0.1, -1.2, 0.7), model="gaussian") == cli


# ---- render ----------------------------------------------------------------------------------

def test_render_equals_cli_float_image(pipeline, tmp_path):
    m = udvr.load(pipeline.model)
    tf = udvr.TransferFunction.from_paraview(str(pipeline.tf))
    img = udvr.render(m, "gaussian", tf, (32, 32))  # = render --size 32x32 --float img.npy
    assert img.shape == (32, 32, 4) and img.dtype == np.float32 and img.flags.owndata is False
    np.testing.assert_array_equal(img, np.load(pipeline.npy))

    # An explicit camera, a non-square image, another model.
    npy = tmp_path / "cam.npy"
    run_ok("render", pipeline.model, "--model", "quantile-range", "--tf", pipeline.tf,
           "--size", "40x24", "--position", "9,4,-20", "--focal-point", "0,0,0.5",
           "--view-up", "0,0,1", "--view-angle", "25", "--float", npy, "-o", tmp_path / "c.png")
    cam = udvr.Camera(position=(9, 4, -20), focal_point=(0, 0, 0.5), view_up=(0, 0, 1),
                      view_angle=25)
    np.testing.assert_array_equal(udvr.render(m, "quantile-range", tf, (40, 24), camera=cam),
                                  np.load(npy))

    # No TF: the CLI's preset over the means and its framed camera.
    npy = tmp_path / "preset.npy"
    run_ok("render", pipeline.model, "--model", "iqr", "--size", "24", "--float", npy,
           "-o", tmp_path / "p.png")
    np.testing.assert_array_equal(udvr.render(m, "iqr", size=24), np.load(npy))


def test_render_field_from_numpy_and_xarray_equals_cli(pipeline, tmp_path):
    npy = tmp_path / "truth.npy"
    run_ok("render", pipeline.field, "--tf", pipeline.tf, "--size", "24", "--float", npy,
           "-o", tmp_path / "t.png")
    f = udvr.read_field(str(pipeline.field))
    tf = udvr.TransferFunction.from_paraview(json.loads(pipeline.tf.read_text()))
    np.testing.assert_array_equal(udvr.render(as_dataarray(f.values.astype(np.float64), f.grid,
                                                           member=False), "mean", tf, 24),
                                  np.load(npy))
    np.testing.assert_array_equal(udvr.render(f, "mean", tf, 24), np.load(npy))


def test_rmse_and_difference_image_equal_compare(pipeline, tmp_path):
    a = np.load(pipeline.npy)
    b = udvr.render(udvr.load(pipeline.model), "uniform", str(pipeline.tf), (32, 32))
    np.save(tmp_path / "b.npy", b)
    r = run_ok("compare", pipeline.npy, tmp_path / "b.npy", "--diff", tmp_path / "d.png")
    assert udvr.rmse(a, b) == pytest.approx(float(r.stdout), abs=1e-8)
    assert udvr.rmse(a.astype(np.float64)[..., :3], b[..., :3]) == pytest.approx(udvr.rmse(a, b))
    diff = udvr.difference_image(a, b)
    assert diff.shape == (32, 32, 4) and np.all(diff[..., 3] == 1)
    # compare --diff adds its colour scale to the right (and rows up to 64 for its labels).
    np.testing.assert_allclose(diff, udvr.read_image(tmp_path / "d.png")[:32, :32],
                               atol=0.5 / 255 + 1e-6)


# ---- the GIL ---------------------------------------------------------------------------------

def count_while(work):
    """How often a Python loop runs while `work` runs in another thread."""
    t = threading.Thread(target=work)
    n = 0
    t.start()
    while t.is_alive():
        n += 1
    t.join()
    return n


def test_render_and_build_release_the_gil(pipeline, ens):
    m = udvr.load(pipeline.model)
    tf = udvr.TransferFunction.from_paraview(pipeline.tf)
    t0 = time.perf_counter()
    udvr.render(m, "gmm-ordered", tf, (200, 200))
    seconds = time.perf_counter() - t0
    n = count_while(lambda: udvr.render(m, "gmm-ordered", tf, (200, 200)))
    # A held GIL lets the counter run only at the interpreter's switch interval (5 ms).
    assert n > 20 * max(1.0, seconds / 0.005), (n, seconds)
    # 20 members of 48³: ~0.1 s of work (16³ took 4 ms, which a busy 2-core machine could finish
    # before this thread was scheduled at all: n = 0 with the GIL released).
    big = np.tile(np.repeat(ens.values, 4, axis=0), (1, 3, 3, 3))
    t0 = time.perf_counter()
    udvr.build(big, quantiles=8, gmm=4, progress=None)
    seconds = time.perf_counter() - t0
    n = count_while(lambda: udvr.build(big, quantiles=8, gmm=4, progress=None))
    assert n > 20 * max(1.0, seconds / 0.005), (n, seconds)


# ---- transfer functions, plots, experiments ---------------------------------------------------

def test_transfer_function_forms_agree(pipeline, tmp_path):
    path = write_tf(tmp_path / "tf.json", [0, 0, 0, 1, 5, 1, 0.5, 0, 10, 1, 1, 0],
                    [0, 0, 0.5, 0, 10, 0.8, 0.5, 0])
    a = udvr.TransferFunction.from_paraview(path)
    b = udvr.TransferFunction(colors=[(0, 0, 0, 1), (5, 1, 0.5, 0), (10, 1, 1, 0)],
                              opacities=[(0, 0), (10, 0.8)])
    x = np.linspace(-1, 11, 25)
    np.testing.assert_array_equal(a(x), b(x))
    np.testing.assert_allclose(a(np.array([5.0]))[0], [1, 0.5, 0, 0.4])
    assert a.colors == b.colors and a.opacities == b.opacities
    c = udvr.TransferFunction.from_paraview(b.to_json("x"))
    np.testing.assert_array_equal(c(x), a(x))
    b.save(tmp_path / "saved.json")
    np.testing.assert_array_equal(udvr.TransferFunction.from_paraview(tmp_path / "saved.json")(x),
                                  a(x))


def test_plots_draw(pipeline):
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    import matplotlib.pyplot as plt
    m = udvr.load(pipeline.model)
    tf = udvr.TransferFunction.from_paraview(pipeline.tf)
    assert tf.plot().axes
    fig = udvr.plot.distribution(m, (3.25, 7.5, 10.125), "quantile-range", tf)
    assert len(fig.axes) == 2
    truth = udvr.render(udvr.load(pipeline.field), "mean", tf, 32)
    imgs = {k: udvr.render(m, k, tf, 32) for k in ("mean", "gaussian")}
    fig = udvr.plot.panel(imgs, truth=truth)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles[1] == f"gaussian\nRMSE {udvr.rmse(imgs['gaussian'], truth):.4f}"
    plt.close("all")


def test_experiment_table_and_figure(tmp_path):
    pytest.importorskip("matplotlib").use("Agg")
    table, figure = udvr.experiment("tangle", quick=True, out=tmp_path, dims=16, members=5,
                                    image_size=32, realizations=4)
    rows = table.to_dict("records") if hasattr(table, "to_dict") else table
    written = json.loads((tmp_path / "results.json").read_text())
    assert [r["label"] for r in rows] == [r["label"] for r in written]
    assert all(set(r) == set(w) for r, w in zip(rows, written))  # results.json's columns
    for r, w in zip(rows, written):
        assert r["rmse"] == pytest.approx(w["rmse"], rel=1e-12, abs=1e-15)
    assert figure and figure.endswith("figure.png")
    assert open(figure, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    # The RMSE of a model is compare's on its images (PNG: 8-bit rounding).
    truth = next(r for r in rows if r["model"] == "ground-truth")
    row = next(r for r in rows if r["model"] == "gaussian")
    printed = float(run_ok("compare", tmp_path / row["image"], tmp_path / truth["image"]).stdout)
    assert row["rmse"] == pytest.approx(printed, abs=3e-3)
    import matplotlib.pyplot as plt
    assert udvr.plot.rmse_curve(table).axes
    plt.close("all")
