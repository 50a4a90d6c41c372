"""`mpirun -np N udvr build … -o m.pvti` (issue 15 point 3): the ranks split the model's z-planes,
each writes its piece, rank 0 the header; the model equals the single-process build bit for bit
(docs/formats.md, "Partitioned models"). Skipped where udvr was built without MPI or there is no
mpirun."""
import os
import shutil
import subprocess

import pytest

from conftest import UDVR_BINARY, assert_one_line_error, run_ok

np = pytest.importorskip("numpy")
udvr = pytest.importorskip("udvr")

pytestmark = pytest.mark.usefixtures("udvr_binary")

MPIRUN = shutil.which("mpirun")


def built_with_mpi():
    out = subprocess.run(["ldd", str(UDVR_BINARY)], capture_output=True, text=True).stdout
    return "libmpi" in out


needs_mpi = pytest.mark.skipif(MPIRUN is None or not built_with_mpi(),
                               reason="no mpirun, or udvr built without MPI")


def mpi_udvr(ranks, *args, timeout=300):
    # OpenMPI refuses root without these; --oversubscribe: more ranks than the CI's 2 cores;
    # -q: no note of its own when a rank exits non-zero (the error stays one line).
    env = dict(os.environ, UDVR_NO_PROGRESS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    return subprocess.run([MPIRUN, "-q", "--oversubscribe", "-np", str(ranks), str(UDVR_BINARY),
                           *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=env, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("mpi")
    run_ok("generate", "tangle", "--dims", "20", "-o", d / "f.vti")
    run_ok("perturb", d / "f.vti", "--members", "9", "-o", d / "e.nc")
    run_ok("generate", "tangle", "--dims", "26", "-o", d / "big.vti")
    return d


ARRAYS = ["mean", "stddev", "min", "max", "quantiles", "iqr", "gmm"]


def assert_same_model(a, b):
    assert tuple(a.grid.dims) == tuple(b.grid.dims)
    for name in ARRAYS:
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.shape == y.shape and np.array_equal(x, y), name


@needs_mpi
@pytest.mark.parametrize("ranks", [1, 2, 3])
def test_ranks_build_the_single_process_model(inputs, tmp_path, ranks):
    run_ok("build", inputs / "e.nc", "--gmm", "3", "-o", tmp_path / "one.vti")
    r = mpi_udvr(ranks, "build", inputs / "e.nc", "--gmm", "3", "-o", tmp_path / "m.pvti")
    assert r.returncode == 0, r.stderr
    assert f"{ranks} rank" in r.stderr
    pieces = sorted(p.name for p in (tmp_path / "m").iterdir())
    assert pieces == [f"m_{i}.vti" for i in range(ranks)]
    assert_same_model(udvr.load(tmp_path / "m.pvti"), udvr.load(tmp_path / "one.vti"))


@needs_mpi
def test_bricks_split_over_ranks(inputs, tmp_path):
    # 26 planes in 2³ bricks: 13 reduced planes over 3 ranks; kde as --downsample's default.
    run_ok("build", inputs / "big.vti", "--downsample", "2", "-o", tmp_path / "one.vti")
    r = mpi_udvr(3, "build", inputs / "big.vti", "--downsample", "2", "-o", tmp_path / "m.pvti")
    assert r.returncode == 0, r.stderr
    assert_same_model(udvr.load(tmp_path / "m.pvti"), udvr.load(tmp_path / "one.vti"))


@needs_mpi
def test_errors_are_said_once_by_rank_0(inputs, tmp_path):
    r = mpi_udvr(3, "build", inputs / "e.nc", "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "mpirun", ".pvti")
    r = mpi_udvr(2, "build", tmp_path / "missing.nc", "-o", tmp_path / "m.pvti")
    assert_one_line_error(r, "missing.nc")
    assert not (tmp_path / "m.pvti").exists() and not (tmp_path / "m").exists()
