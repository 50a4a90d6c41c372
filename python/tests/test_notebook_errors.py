"""Bad input to the notebook API (issue 14, point 3): errors from the library arrive as ValueError
(values) or OSError (files) with the CLI's message; wrong kinds of argument, dtypes that are not
real (complex, object, strings) and wrong shapes are refused before any work starts."""
import numpy as np
import pytest

from conftest import run_udvr, write_tf

udvr = pytest.importorskip("udvr")


def cli_error(*args):
    """The CLI's one-line message for the same mistake, without 'udvr: error: '."""
    r = run_udvr(*args)
    assert r.returncode != 0
    return r.stderr.strip().removeprefix("udvr: error: ")


@pytest.fixture(scope="module")
def model(pipeline):
    return udvr.load(pipeline.model)


def test_library_errors_carry_the_cli_message(pipeline, model, tmp_path):
    with pytest.raises(ValueError) as e:
        udvr.render(model, "quantile", str(pipeline.tf))
    assert str(e.value) == cli_error("render", pipeline.model, "--model", "quantile", "--tf",
                                     pipeline.tf, "-o", tmp_path / "x.png")
    with pytest.raises(ValueError) as e:
        model.probe((1, 2, 99), model="gaussian", tf=str(pipeline.tf))
    assert str(e.value) == cli_error("probe", pipeline.model, "--point", "1,2,99", "--model",
                                     "gaussian", "--tf", pipeline.tf, "--json")
    with pytest.raises(ValueError) as e:
        udvr.build(str(pipeline.ensemble), gmm=99)
    assert str(e.value) == cli_error("build", pipeline.ensemble, "--gmm", "99", "-o",
                                     tmp_path / "m.vti")
    with pytest.raises(ValueError) as e:
        udvr.build(str(pipeline.ensemble), density="histogram")
    assert str(e.value) == cli_error("build", pipeline.ensemble, "--density", "histogram", "-o",
                                     tmp_path / "m.vti")
    bad = write_tf(tmp_path / "bad.json", raw='[{"RGBPoints": [0, 0, 0], "Points": [0, 1, 0.5, 0]}]')
    with pytest.raises(ValueError) as e:
        udvr.TransferFunction.from_paraview(bad)
    assert str(e.value) == cli_error("render", pipeline.model, "--tf", bad, "-o",
                                     tmp_path / "x.png")
    a, b = np.zeros((4, 4, 4), np.float32), np.zeros((4, 5, 4), np.float32)
    np.save(tmp_path / "a.npy", a)
    np.save(tmp_path / "b.npy", b)
    with pytest.raises(ValueError) as e:
        udvr.rmse(a, b)
    assert str(e.value) == cli_error("compare", tmp_path / "a.npy", tmp_path / "b.npy")


def test_file_errors_are_oserror_with_the_cli_message(pipeline, model, tmp_path):
    missing = tmp_path / "missing.vti"
    with pytest.raises(OSError) as e:
        udvr.load(missing)
    assert str(e.value) == cli_error("render", missing, "-o", tmp_path / "x.png")
    with pytest.raises(OSError, match="no such file"):
        udvr.build(str(tmp_path / "missing.nc"))
    with pytest.raises(OSError, match="cannot open transfer function"):
        udvr.render(model, "mean", str(tmp_path / "missing.json"))
    with pytest.raises(OSError, match="does not exist"):
        model.save(tmp_path / "no" / "such" / "folder" / "m.vti")
    with pytest.raises(ValueError, match=r"\.vti"):
        model.save(tmp_path / "m.png")


@pytest.mark.parametrize("dtype", [np.complex64, object, "U3", "datetime64[s]"])
def test_non_real_dtypes_are_type_errors(dtype, model):
    bad = np.zeros((3, 4, 4, 4)).astype(dtype)
    with pytest.raises(TypeError, match="real numbers"):
        udvr.build(bad)
    with pytest.raises(TypeError, match="real numbers"):
        udvr.render(bad[0], "mean")
    with pytest.raises(TypeError, match="real numbers"):
        udvr.rmse(bad[0], np.zeros((4, 4, 4)))
    with pytest.raises(TypeError, match="real numbers"):
        udvr.Model(bad[0])
    with pytest.raises(TypeError, match="real numbers"):
        udvr.Field(bad[0])
    with pytest.raises(TypeError, match="real numbers"):
        udvr.TransferFunction.preset_over("viridis", bad)


def test_shapes_counts_and_names_are_checked_first(model):
    with pytest.raises(ValueError, match="3 or 4 dimensions"):
        udvr.build(np.zeros((5, 4)))
    with pytest.raises(ValueError, match="downsample=K"):
        udvr.build(np.zeros((4, 4, 4)))
    with pytest.raises(ValueError, match="drop downsample"):
        udvr.build(np.zeros((3, 4, 4, 4)), downsample=2)
    with pytest.raises(TypeError, match="integer"):
        udvr.build(np.zeros((3, 4, 4, 4)), quantiles=2.5)
    with pytest.raises(ValueError, match=r"must have shape \(2, 2, 2\)"):
        udvr.Model(np.zeros((2, 2, 2)), stddev=np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="NaN or Inf"):
        udvr.Model(np.full((2, 2, 2), np.nan))
    with pytest.raises(ValueError, match="unknown model 'gmm'"):
        model.probe((1, 1, 1), model="gmm", tf="/no/such/tf.json")  # the name before the TF
    with pytest.raises(ValueError, match="unknown model"):
        udvr.render(model, "bogus", size=0)  # before the size
    with pytest.raises(ValueError, match="neither a file nor a preset"):
        udvr.render(model, "mean", "rainbow")
    with pytest.raises(ValueError, match="each side"):
        udvr.render(model, "mean", size=(0, 10))
    with pytest.raises(TypeError):
        udvr.render(model, "mean", size="big")
    with pytest.raises(TypeError, match="udvr.Model"):
        udvr.render(42, "mean")
    with pytest.raises(ValueError, match="focal point must differ"):
        udvr.Camera(position=(1, 2, 3), focal_point=(1, 2, 3))
    with pytest.raises(ValueError, match="unknown experiment"):
        udvr.experiment("tangel")
    with pytest.raises(ValueError, match="spacing must be positive"):
        udvr.build(np.zeros((3, 4, 4, 4)), spacing=(1, 0, 1))


def test_nan_samples_stop_the_build_before_statistics():
    e = np.random.default_rng(2).normal(size=(6, 5, 6, 7))
    e[4, 3, 2, 1] = np.nan
    calls = []
    with pytest.raises(ValueError) as err:
        udvr.build(e, progress=lambda d, t: calls.append(d))
    assert str(err.value) == ("the ensemble has 1 NaN/Inf samples (first at voxel (1,2,3), "
                              "member 4); build needs finite values and never averages NaN "
                              "(--nan skip: each voxel's finite members only)")
    assert all(d == 0 for d in calls)  # no voxel was modelled


def test_xarray_inputs_are_checked(pipeline):
    xr = pytest.importorskip("xarray")
    e = np.zeros((3, 4, 4, 4))
    with pytest.raises(ValueError, match="no member dimension"):
        udvr.build(xr.DataArray(e, dims=("run", "z", "y", "x")))
    udvr.build(xr.DataArray(e, dims=("run", "z", "y", "x")), member_dim="run", gmm=2,
               quantiles=2)
    with pytest.raises(ValueError, match="unevenly spaced"):
        udvr.build(xr.DataArray(e, dims=("member", "z", "y", "x"),
                                coords={"x": [0.0, 1.0, 2.0, 4.0]}))
    with pytest.raises(ValueError, match="must increase"):
        udvr.build(xr.DataArray(e, dims=("member", "z", "y", "x"),
                                coords={"y": [3.0, 2.0, 1.0, 0.0]}))
    with pytest.raises(TypeError, match="DataArray"):
        udvr.build(xr.Dataset({"v": (("member", "z", "y", "x"), e)}))
