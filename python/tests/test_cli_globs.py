"""A quoted glob where one field or model is read (issue 35): render, probe, info, build
--downsample and Python's load/render take a pattern that matches one file as that file (the
same bytes out); a pattern matching several files is one error line naming two of them and
what to do; Python renders model 'members' from a (members, z, y, x) array."""
import numpy as np
import pytest

from conftest import assert_one_line_error, run_ok, run_udvr

udvr = pytest.importorskip("udvr")
pytestmark = pytest.mark.usefixtures("udvr_binary")


def two_fields(tmp_path):
    rng = np.random.default_rng(35)
    for name in ("run01_05_a.vti", "run02_05_b.vti"):
        udvr.write_field(str(tmp_path / name),
                         udvr.Field(rng.uniform(0, 1, (6, 7, 8)).astype(np.float32)))
    return tmp_path / "run01_05_a.vti"


def test_a_glob_of_one_file_reads_that_file(tmp_path):
    one = two_fields(tmp_path)
    pattern = str(tmp_path / "run01_05*.vti")
    size = ["--size", "24x16"]
    run_ok("render", one, *size, "--float", tmp_path / "a.npy", "-o", tmp_path / "a.png")
    run_ok("render", pattern, *size, "--float", tmp_path / "b.npy", "-o", tmp_path / "b.png")
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    assert np.array_equal(np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy"))
    probe = ["--point", "1.5,2.5,3.5", "--json"]
    assert run_ok("probe", one, *probe).stdout == run_ok("probe", pattern, *probe).stdout
    assert "6x7x8" in run_ok("info", pattern).stdout.replace(" ", "") or \
        "8x7x6" in run_ok("info", pattern).stdout
    run_ok("build", one, "--downsample", "2", "--gmm", "0", "-o", tmp_path / "m1.vti")
    run_ok("build", pattern, "--downsample", "2", "--gmm", "0", "-o", tmp_path / "m2.vti")
    m1, m2 = udvr.load(str(tmp_path / "m1.vti")), udvr.load(str(tmp_path / "m2.vti"))
    assert np.array_equal(m1.quantiles, m2.quantiles) and m1.quantiles.shape[:3] == (3, 3, 4)
    # Python: load and render take the pattern too.
    assert np.array_equal(udvr.load(pattern).mean, udvr.load(str(one)).mean)


def test_a_glob_of_several_files_is_one_error_line(tmp_path):
    two_fields(tmp_path)
    pattern = str(tmp_path / "run*_05*.vti")
    for args in (["render", pattern, "-o", tmp_path / "x.png"],
                 ["probe", pattern, "--point", "1,1,1"],
                 ["build", pattern, "--downsample", "2", "-o", tmp_path / "m.vti"]):
        assert_one_line_error(run_udvr(*args), "matches 2 files", "run01_05_a.vti",
                              "run02_05_b.vti", "--model members")
    assert_one_line_error(run_udvr("render", str(tmp_path / "zz*.vti"), "-o", tmp_path / "x.png"),
                          "matches no files")
    assert not (tmp_path / "x.png").exists() and not (tmp_path / "m.vti").exists()
    with pytest.raises(ValueError, match="matches 2 files"):
        udvr.load(pattern)


def test_python_renders_members_of_an_array_as_their_tf_average():
    # n identical members: the members' TF average is the mean field's image, exactly.
    rng = np.random.default_rng(3)
    field = rng.uniform(0, 1, (5, 6, 7)).astype(np.float32)
    tf = udvr.TransferFunction.preset("viridis", (0.0, 1.0), 0.2)
    same = np.repeat(field[None], 4, axis=0)
    got = udvr.render(same, "members", tf, (20, 12), azimuth=10, elevation=5)
    want = udvr.render(field, "mean", tf, (20, 12), azimuth=10, elevation=5)
    assert np.abs(got - want).max() <= 1e-6 and want[..., 3].max() > 0.05  # float sums
    # Two members: the average of the two classifications, not the classification of the
    # average, so it differs from the mean field's image.
    pair = np.stack([field, 1.0 - field])
    two = udvr.render(pair, "members", tf, (20, 12), azimuth=10, elevation=5)
    mean = udvr.render(pair.mean(axis=0), "mean", tf, (20, 12), azimuth=10, elevation=5)
    assert np.abs(two - mean).max() > 0.05
