"""udvr.Model from NumPy arrays: round trip through write_model/read_model, and bad input."""
import numpy as np
import pytest

udvr = pytest.importorskip("udvr")


def arrays(shape=(2, 3, 4), q=4, K=2):
    rng = np.random.default_rng(0)
    mean = rng.random(shape).astype(np.float32)
    b = np.sort(rng.random(shape + (q + 1,)), -1).astype(np.float32)
    gmm = rng.random(shape + (3 * K,)).astype(np.float32)
    return dict(mean=mean, stddev=mean * 0.1, min=mean - 1, max=mean + 1, quantiles=b,
                iqr=b[..., [1, 3]], gmm=gmm)


def test_round_trip_keeps_arrays_and_geometry(tmp_path):
    a = arrays()
    m = udvr.Model(a["mean"], stddev=a["stddev"], min=a["min"], max=a["max"],
                   quantiles=a["quantiles"], iqr=a["iqr"], gmm=a["gmm"], origin=[1, 2, 3],
                   spacing=[0.5, 1, 2], bounds=[0, 3, 1, 5, 2, 6], full_res_min_spacing=0.25,
                   downsample=2, samples_per_voxel=8)
    assert m.grid.dims == [4, 3, 2] and m.quantile_count == 4 and m.gmm_components == 2
    udvr.write_model(str(tmp_path / "m.vti"), m)
    r = udvr.read_model(str(tmp_path / "m.vti"))
    for k, v in a.items():
        np.testing.assert_array_equal(r.array(k), v, err_msg=k)
    assert r.grid.origin == [1, 2, 3] and r.grid.spacing == [0.5, 1, 2]
    assert list(r.bounds) == [0, 3, 1, 5, 2, 6] and r.full_res_min_spacing == 0.25
    assert r.downsample == 2 and r.samples_per_voxel == 8


def test_defaults_mean_only():
    m = udvr.Model(np.zeros((2, 2, 3), np.float32), origin=[1, 1, 1], spacing=[2, 0.5, 1])
    assert list(m.bounds) == [1, 5, 1, 1.5, 1, 2] and m.full_res_min_spacing == 0.5
    np.testing.assert_array_equal(m.array("stddev"), 0)
    assert m.quantile_count == 0 and m.gmm_components == 0


@pytest.mark.parametrize("bad", [
    dict(stddev=np.zeros((2, 3, 5), np.float32)),
    dict(quantiles=np.zeros((2, 3, 4), np.float32)),
    dict(quantiles=np.zeros((2, 3, 4, 1), np.float32)),
    dict(iqr=np.zeros((2, 3, 4, 3), np.float32)),
    dict(gmm=np.zeros((2, 3, 4, 4), np.float32)),
    dict(spacing=[1, 0, 1]),
    dict(full_res_min_spacing=-1.0),
])
def test_bad_arrays_raise_value_error(bad):
    a = arrays()
    with pytest.raises(ValueError):
        udvr.Model(a["mean"], **bad)


def test_nan_is_rejected():
    a = arrays()
    a["mean"][0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        udvr.Model(a["mean"])
