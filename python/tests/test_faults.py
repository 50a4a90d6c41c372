"""Faults (issue 15, point 5): a killed command leaves no partial output; a full disk, the file
size limit and an unwritable directory are one-line errors that leave no temporary file; NaN/Inf
members follow `build --nan error|skip` (docs/formats.md, "Output files" and "NaN and Inf").

Outputs go to a hidden temporary `.STEM.tmpPID.EXT` beside the destination and are renamed
onto it when complete. The kill tests catch a command while its temporary exists (polling the
directory), so they test the write itself, not only the work before it.
"""
import os
import pathlib
import re
import resource
import shutil
import signal
import subprocess
import tempfile
import time

import pytest

from conftest import UDVR_BINARY, assert_one_line_error, run_ok, run_udvr, write_nrrd, write_tf

np = pytest.importorskip("numpy")

pytestmark = pytest.mark.usefixtures("udvr_binary")

TEMP = re.compile(r"^\..+\.tmp(\d+)(\.[A-Za-z0-9]+)?$")


def temporaries(directory):
    return sorted(p.name for p in pathlib.Path(directory).iterdir() if TEMP.match(p.name))


def default_signals():
    """In the child: SIGINT and SIGQUIT back to their defaults. A test run started in the
    background (`cmd &` in a script, nohup) ignores them, the child inherits that, and udvr keeps
    a signal its parent ignores ignored (atomic_file.cpp) — as a user's background job wants."""
    for sig in (signal.SIGINT, signal.SIGQUIT):
        signal.signal(sig, signal.SIG_DFL)


def start(*args, **kw):
    env = dict(os.environ, UDVR_NO_PROGRESS="1")
    return subprocess.Popen([str(UDVR_BINARY), *map(str, args)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, env=env,
                            preexec_fn=default_signals, **kw)


def kill_while_writing(args, directory, sig=signal.SIGKILL, timeout=60):
    """Start udvr, send `sig` as soon as its temporary output appears in `directory`; returns
    (the temporaries seen then, the exit code). Fails if the command ended without one."""
    p = start(*args)
    deadline = time.monotonic() + timeout
    seen = []
    while time.monotonic() < deadline:
        seen = [n for n in os.listdir(directory)
                if (m := TEMP.match(n)) and m.group(1) == str(p.pid)]
        if seen or p.poll() is not None:
            break
    if seen:
        p.send_signal(sig)
    rc = p.wait(timeout=timeout)
    p.stderr.close()
    assert seen, f"udvr {' '.join(map(str, args))} ended (exit {rc}) before its write was seen"
    return seen, rc


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("fault_inputs")
    run_ok("generate", "tangle", "--dims", "32", "-o", d / "f.vti")
    run_ok("perturb", d / "f.vti", "--members", "10", "-o", d / "e.nc")
    write_tf(d / "tf.json", [-10, 0, 0, 1, 30, 1, 1, 0], [-10, 0, 0.5, 0, 30, 0.5, 0.5, 0])
    return d


# q = 500 boundaries per voxel: a 66 MB model from a 32³ ensemble, written for tens of ms.
def big_build(inputs, out):
    return ["build", inputs / "e.nc", "--quantiles", "500", "--gmm", "0", "-o", out]


def test_kill9_during_build_write_leaves_no_output(inputs, tmp_path):
    out = tmp_path / "m.vti"
    seen, rc = kill_while_writing(big_build(inputs, out), tmp_path)
    assert rc == -signal.SIGKILL
    assert not out.exists()
    # SIGKILL cannot be caught: the temporary stays, hidden and named after the dead process.
    assert temporaries(tmp_path) == seen
    # The next write of the same destination removes it.
    run_ok("build", inputs / "e.nc", "--gmm", "0", "-o", out)
    assert temporaries(tmp_path) == [] and out.exists()


def test_kill9_during_build_keeps_the_previous_file(inputs, tmp_path):
    out = tmp_path / "m.vti"
    run_ok("build", inputs / "e.nc", "--gmm", "0", "-o", out)
    before = out.read_bytes()
    kill_while_writing(big_build(inputs, out), tmp_path)
    assert out.read_bytes() == before


def cpu_seconds(pid):
    """User + system CPU time of a running process, from /proc/PID/stat (fields 14 and 15)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_kill9_before_the_write_leaves_nothing(tmp_path):
    # A 64³ ensemble with GMM K = 4 works for about 0.2 s before it writes: kill it once it has
    # spent 20 ms of CPU, while it is still running and its temporary has not appeared.
    run_ok("generate", "tangle", "--dims", "64", "-o", tmp_path / "f.vti")
    run_ok("perturb", tmp_path / "f.vti", "--members", "10", "-o", tmp_path / "e.nc")
    out = tmp_path / "out" / "m.vti"
    out.parent.mkdir()
    p = start("build", tmp_path / "e.nc", "--gmm", "4", "--quantiles", "64", "-o", out)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and p.poll() is None and cpu_seconds(p.pid) < 0.02:
        time.sleep(0.001)
    still_working = p.poll() is None and temporaries(out.parent) == []
    p.kill()
    p.wait(timeout=60)
    p.stderr.close()
    assert still_working, "the build wrote or ended before 20 ms of CPU: make its input larger"
    assert list(out.parent.iterdir()) == []


def test_kill9_during_render_write_leaves_no_output(inputs, tmp_path):
    out = tmp_path / "i.png"
    kill_while_writing(["render", inputs / "f.vti", "--size", "2500", "-o", out], tmp_path)
    assert not out.exists()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_during_write_removes_the_temporary(inputs, tmp_path, sig):
    out = tmp_path / "m.vti"
    _, rc = kill_while_writing(big_build(inputs, out), tmp_path, sig=sig)
    assert rc == -sig  # terminated by the signal, as without the handler
    assert not out.exists() and temporaries(tmp_path) == []


def test_kill9_during_experiment_leaves_only_whole_files(tmp_path):
    out = tmp_path / "exp"
    p = start("experiment", "tangle", "--quick", "-o", out)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and p.poll() is None:
        if (out / "images").is_dir() and len(list((out / "images").glob("*.png"))) >= 3:
            break
        time.sleep(0.01)
    p.kill()
    p.wait(timeout=60)
    p.stderr.close()
    pngs = [p for p in out.rglob("*.png") if not p.name.startswith(".")]
    assert pngs, "the experiment wrote no image before it was killed"
    for png in pngs:  # every visible PNG is complete: it ends with the IEND chunk
        assert png.read_bytes()[-12:] == b"\x00\x00\x00\x00IEND\xaeB`\x82", png


# ---- unwritable directory, file size limit, full disk --------------------------------------

def _as_nobody():
    """(argv prefix, a world-writable scratch dir) to run udvr as an unprivileged user: root
    writes into read-only directories, so root runs udvr as nobody through setpriv."""
    if os.geteuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        pytest.skip("running as root without setpriv: cannot test an unwritable directory")
    prefix = [setpriv, "--reuid=65534", "--regid=65534", "--clear-groups"]
    if subprocess.run([*prefix, str(UDVR_BINARY), "--version"], capture_output=True).returncode:
        pytest.skip(f"user nobody cannot run {UDVR_BINARY} (a private home directory?)")
    return prefix


@pytest.fixture
def open_dir():
    """A scratch directory every user can read (the pytest tmp_path is private to its user)."""
    d = pathlib.Path(tempfile.mkdtemp(prefix="udvr_faults_"))
    d.chmod(0o755)
    yield d
    for p in d.rglob("*"):
        if p.is_dir():
            p.chmod(0o755)
    shutil.rmtree(d)


@pytest.mark.parametrize("command", [
    lambda d: ["build", d / "e.nc", "--gmm", "0", "-o", d / "ro" / "m.vti"],
    lambda d: ["render", d / "f.vti", "--size", "16", "-o", d / "ro" / "i.png"],
    lambda d: ["render", d / "f.vti", "--size", "16", "-o", d / "i.png", "--float",
               d / "ro" / "i.npy"],
    lambda d: ["perturb", d / "f.vti", "--members", "2", "-o", d / "ro" / "e.nc"],
    lambda d: ["generate", "tangle", "--dims", "8", "-o", d / "ro" / "g.vti"],
], ids=["build", "render", "render-float", "perturb", "generate"])
def test_unwritable_directory_is_one_line_and_leaves_nothing(command, open_dir):
    run_ok("generate", "tangle", "--dims", "8", "-o", open_dir / "f.vti")
    run_ok("perturb", open_dir / "f.vti", "--members", "3", "-o", open_dir / "e.nc")
    for p in open_dir.iterdir():
        p.chmod(0o644)
    (open_dir / "ro").mkdir(mode=0o555)
    (open_dir / "ro").chmod(0o555)
    (open_dir).chmod(0o777)  # render's -o beside the inputs
    args = [str(a) for a in command(open_dir)]
    r = subprocess.run([*_as_nobody(), str(UDVR_BINARY), *args], capture_output=True, text=True,
                       timeout=60, env=dict(os.environ, UDVR_NO_PROGRESS="1"))
    assert_one_line_error(r, "not writable", "permission denied")
    assert list((open_dir / "ro").iterdir()) == []


def _file_size_limit(limit):
    def set_limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return set_limit


def run_limited(limit, *args):
    """udvr under a file size limit (ulimit -f): writes past it fail with EFBIG (udvr ignores
    SIGXFSZ, which would otherwise kill it)."""
    return subprocess.run([str(UDVR_BINARY), *map(str, args)], capture_output=True, text=True,
                          timeout=120, preexec_fn=_file_size_limit(limit),
                          env=dict(os.environ, UDVR_NO_PROGRESS="1"))


@pytest.mark.parametrize("cut", [1, 20, 4096, 0.5, 0.01])
def test_file_size_limit_during_model_write(inputs, tmp_path, cut):
    whole = tmp_path / "whole.vti"
    run_ok("build", inputs / "e.nc", "-o", whole)
    size = whole.stat().st_size
    limit = int(size * cut) if isinstance(cut, float) else size - cut
    out = tmp_path / "m.vti"
    r = run_limited(limit, "build", inputs / "e.nc", "-o", out)
    assert_one_line_error(r, "cannot write", "m.vti", "file too large")
    assert not out.exists() and temporaries(tmp_path) == []


@pytest.mark.parametrize("command", [
    lambda i, t: ["render", i / "f.vti", "--tf", i / "tf.json", "--size", "256", "-o",
                  t / "o.png"],
    lambda i, t: ["render", i / "f.vti", "--tf", i / "tf.json", "--size", "256", "-o",
                  t / "i.png", "--float", t / "o.npy"],
    lambda i, t: ["perturb", i / "f.vti", "--members", "3", "-o", t / "o.nc"],
    lambda i, t: ["generate", "tangle", "--dims", "32", "-o", t / "o.vti"],
    lambda i, t: ["generate", "tangle", "--dims", "32", "-o", t / "o.nc"],
], ids=["render-png", "render-npy", "perturb-nc", "generate-vti", "generate-nc"])
def test_file_size_limit_for_other_writers(inputs, tmp_path, command):
    args = command(inputs, tmp_path)
    r = run_limited(20000, *args)
    assert_one_line_error(r, "cannot write", "file too large")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(("o.", ".o."))]
    assert temporaries(tmp_path) == []


def test_full_disk_is_one_line_and_leaves_nothing(inputs, tmp_path):
    """A real ENOSPC: a 1 MiB tmpfs mounted in a private mount namespace (unshare), which
    disappears with the command; skipped where unshare or mount are not allowed."""
    unshare = shutil.which("unshare")
    probe = subprocess.run([unshare or "unshare", "-m", "-r", "true"], capture_output=True) \
        if unshare else None
    if probe is None or probe.returncode != 0:
        pytest.skip("no unshare -m -r here: cannot mount a small tmpfs")
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    script = (f'mount -t tmpfs -o size=1m tmpfs "{mnt}" || exit 99; '
              f'UDVR_NO_PROGRESS=1 "{UDVR_BINARY}" build "{inputs / "e.nc"}" -o "{mnt}/m.vti"; '
              f'echo "rc=$?" >&2; ls -a "{mnt}" >&2')
    r = subprocess.run([unshare, "-m", "-r", "sh", "-c", script], capture_output=True,
                       text=True, timeout=120)
    if r.returncode == 99:
        pytest.skip("mount not allowed in a user namespace here")
    lines = [l for l in r.stderr.splitlines() if not l.startswith(("build:", "udvr: warning"))]
    assert lines[0].startswith("udvr: error: cannot write") and "no space left" in lines[0].lower()
    assert "rc=2" in lines
    assert sorted(lines[lines.index("rc=2") + 1:]) == [".", ".."]  # nothing left on the disk


# ---- NaN / Inf: build --nan error|skip -----------------------------------------------------

def _members(tmp_path, values):
    """Member NRRD files of a (members, z, y, x) array."""
    paths = []
    for m, v in enumerate(values):
        z, y, x = v.shape
        paths.append(write_nrrd(tmp_path / f"m{m:02d}.nrrd", v.ravel().tolist(), (x, y, z)))
    return paths


def _ensemble_with_holes(seed=3, members=9):
    rng = np.random.default_rng(seed)
    a = (rng.normal(size=(members, 4, 5, 6)) + np.where(rng.random((members, 4, 5, 6)) < 0.3,
                                                       3.0, 0.0)).astype(np.float32)
    a[2, 1, 2, 3] = np.nan
    a[0, 0, 0, 1] = np.inf
    a[:7, 3, 4, 5] = np.nan  # 2 finite samples left, fewer than K = 4
    a[4, 2, :, :] = -np.inf  # a whole plane of one member
    return a


def test_nan_default_is_one_line_naming_the_member_file_and_voxel(tmp_path):
    a = _ensemble_with_holes()
    paths = _members(tmp_path, a)
    r = run_udvr("build", *paths, "-o", tmp_path / "m.vti")
    # The first member file with NaN/Inf (m00: the Inf at (i,j,k) = (1,0,0)).
    assert_one_line_error(r, "m00.nrrd", "(1,0,0)")
    assert not (tmp_path / "m.vti").exists()
    # The same through the library: the first voxel in grid order, and its member.
    import udvr
    with pytest.raises(ValueError, match=r"first at voxel \(1,0,0\), member 0.*--nan skip"):
        udvr.build(a)


def test_nan_skip_matches_numpy_on_the_finite_members(tmp_path):
    import udvr
    a = _ensemble_with_holes()
    paths = _members(tmp_path, a)
    out = tmp_path / "m.vti"
    r = run_ok("build", *paths, "--nan", "skip", "-o", out)
    finite = np.isfinite(a)
    assert f"left out {(~finite).sum()} NaN/Inf samples at " \
           f"{(~finite).any(axis=0).sum()} voxels (the fewest finite samples at a voxel: 2 of 9)" \
        in r.stderr
    m = udvr.load(out)
    b = np.where(finite, a, np.nan).astype(np.float64)
    np.testing.assert_allclose(m.mean, np.nanmean(b, axis=0), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(m.stddev, np.nanstd(b, axis=0, ddof=1), rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(m.min, np.nanmin(b, axis=0).astype(np.float32))
    np.testing.assert_array_equal(m.max, np.nanmax(b, axis=0).astype(np.float32))
    q = np.moveaxis(np.nanquantile(b, np.linspace(0, 1, 9), axis=0), 0, -1)
    np.testing.assert_allclose(m.quantiles, q, rtol=1e-5, atol=1e-5)
    iqr = np.moveaxis(np.nanquantile(b, [0.25, 0.75], axis=0), 0, -1)
    np.testing.assert_allclose(m.iqr, iqr, rtol=1e-5, atol=1e-5)
    g = m.gmm  # (z, y, x, 12): π, μ, σ
    np.testing.assert_allclose(g[..., :4].sum(axis=-1), 1.0, atol=1e-6)
    np.testing.assert_allclose((g[..., :4] * g[..., 4:8]).sum(axis=-1), np.nanmean(b, axis=0),
                               atol=2e-3)
    assert (g[3, 4, 5, :4] > 0).sum() <= 2  # 2 finite samples: at most 2 components
    # The Python API gives the same model from the array.
    arr = udvr.build(a, nan="skip", progress=False)
    for name in ("mean", "stddev", "quantiles", "gmm"):
        np.testing.assert_array_equal(getattr(arr, name), getattr(m, name))


def test_nan_skip_needs_two_finite_samples_per_voxel(tmp_path):
    a = _ensemble_with_holes()
    a[1:, 0, 1, 2] = np.nan
    r = run_udvr("build", *_members(tmp_path, a), "--nan", "skip", "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "--nan skip", "voxel (2,1,0) has 1 of 9")
    r = run_udvr("build", *_members(tmp_path, a), "--nan", "drop", "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "--nan", "drop", "error or skip")
    assert not (tmp_path / "m.vti").exists()


def test_nan_skip_reads_netcdf_fill_values_as_missing(tmp_path):
    import udvr
    netcdf = pytest.importorskip("scipy.io").netcdf_file
    a = _ensemble_with_holes()
    a[~np.isfinite(a)] = -999.0
    f = netcdf(str(tmp_path / "e.nc"), "w")
    for name, n in zip(("member", "z", "y", "x"), a.shape):
        f.createDimension(name, n)
    v = f.createVariable("val", "f4", ("member", "z", "y", "x"))
    v[:] = a
    v._FillValue = np.float32(-999.0)
    f.close()
    r = run_udvr("build", tmp_path / "e.nc", "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "e.nc", "fill")
    run_ok("build", tmp_path / "e.nc", "--nan", "skip", "-o", tmp_path / "m.vti")
    m = udvr.load(tmp_path / "m.vti")
    b = np.where(a == -999.0, np.nan, a).astype(np.float64)
    np.testing.assert_allclose(m.mean, np.nanmean(b, axis=0), rtol=1e-5, atol=1e-6)


def test_nan_skip_on_bricks_of_one_field(tmp_path):
    import udvr
    rng = np.random.default_rng(5)
    f = rng.normal(size=(4, 6, 8)).astype(np.float32)
    f[0, 0, 0] = np.nan
    f[3, 5, 7] = np.inf
    path = write_nrrd(tmp_path / "f.nrrd", f.ravel().tolist(), (8, 6, 4))
    r = run_udvr("build", path, "--downsample", "2", "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "f.nrrd", "(0,0,0)")
    run_ok("build", path, "--downsample", "2", "--density", "empirical", "--nan", "skip", "-o",
           tmp_path / "m.vti")
    m = udvr.load(tmp_path / "m.vti")
    bricks = f.reshape(2, 2, 3, 2, 4, 2).transpose(0, 2, 4, 1, 3, 5).reshape(2, 3, 4, 8)
    b = np.where(np.isfinite(bricks), bricks, np.nan).astype(np.float64)
    np.testing.assert_allclose(m.mean, np.nanmean(b, axis=-1), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(m.quantiles, np.nanquantile(b, np.linspace(0, 1, 9), axis=-1)
                               .transpose(1, 2, 3, 0), rtol=1e-5, atol=1e-5)
