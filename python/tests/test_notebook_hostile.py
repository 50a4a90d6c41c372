"""The Python module against careless and hostile input (issue 34, items 10-14): a deeply nested
.vti, arrays no field or model holds, internal checks reached from valid calls, a progress
callback that raises, Ctrl-C in a long render, unbounded thread counts and experiment sizes.
"""
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

udvr = pytest.importorskip("udvr")

from conftest import BUILD  # noqa: E402


def test_deeply_nested_vti_is_a_value_error_not_a_crash(tmp_path):
    # In a child process: before the fix the interpreter died of SIGSEGV.
    deep = tmp_path / "deep.vti"
    deep.write_text('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" '
                    'byte_order="LittleEndian">' + "<a>" * 150_000 + "</a>" * 150_000 +
                    "</VTKFile>\n")
    code = textwrap.dedent(f"""
        import udvr
        try:
            udvr.load({str(deep)!r})
        except ValueError as e:
            print("ValueError:", e)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, PYTHONPATH=str(BUILD / "python")))
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr}"
    assert "ValueError:" in r.stdout and "nested deeper than 256" in r.stdout


def test_nan_in_a_field_names_the_voxel():
    v = np.zeros((4, 5, 6), np.float32)
    v[3, 2, 1] = np.nan
    with pytest.raises(ValueError, match=r"NaN at voxel \(1, 2, 3\)"):
        udvr.Field(v)
    v[3, 2, 1] = np.inf
    with pytest.raises(ValueError, match="Inf"):
        udvr.render(v, size=8)


@pytest.mark.parametrize("origin,spacing", [((0, 0, np.nan), (1, 1, 1)),
                                            ((0, 0, 0), (1, np.inf, 1)),
                                            ((0, 0, 0), (1, -1, 1))])
def test_bad_field_geometry_is_a_value_error(origin, spacing):
    with pytest.raises(ValueError, match="spacing must be positive and origin finite"):
        udvr.Field(np.zeros((2, 2, 2), np.float32), origin, spacing)


def model_arrays():
    mean = np.ones((2, 3, 4), np.float32)
    return dict(mean=mean, stddev=mean * 0.1, min=mean - 1, max=mean + 1,
                quantiles=np.broadcast_to(np.float32([0, 1, 2]), (2, 3, 4, 3)).copy(),
                gmm=np.broadcast_to(np.float32([1, 1, 0.5]), (2, 3, 4, 3)).copy())


@pytest.mark.parametrize("name,index,value,match", [
    ("stddev", (1, 2, 3), -0.5, r"array 'stddev' is negative \(-0.5\) at voxel \(3, 2, 1\)"),
    ("stddev", (0, 0, 1), 3e38, r"array 'stddev' is 3e\+38, over 1e\+18 at voxel \(1, 0, 0\)"),
    ("quantiles", (1, 0, 0, 2), -1, r"array 'quantiles' decreases.*at voxel \(0, 0, 1\)"),
    ("gmm", (0, 1, 0, 2), -2, r"array 'gmm' component 0 sigma is negative"),
    ("min", (0, 0, 0), 7, r"array 'min' is 7, over max 2 at voxel \(0, 0, 0\)"),
])
def test_impossible_model_arrays_name_array_and_voxel(name, index, value, match):
    a = model_arrays()
    a[name][index] = value
    with pytest.raises(ValueError, match=match):
        udvr.Model(a.pop("mean"), **a)


def test_build_of_an_empty_axis_is_a_value_error():
    with pytest.raises(ValueError, match=r"\(5, 0, 8, 8\) array is empty along axis 1"):
        udvr.build(np.zeros((5, 0, 8, 8), np.float32))


def test_constant_1e17_field_renders_with_the_default_tf():
    img = udvr.render(np.full((4, 4, 4), 1e17, np.float32), size=8)
    assert np.isfinite(img).all()


def test_progress_callback_exception_propagates_and_stops_the_build():
    # Large enough that the whole build takes several of the callback's 0.1 s periods: 40³ took
    # 0.063 s on an AVX-512 machine, so the only callback came at the end (stopped = whole).
    data = np.random.default_rng(0).random((20, 96, 96, 96), dtype=np.float32)
    t = time.monotonic()
    udvr.build(data, quantiles=8, gmm=4, progress=None)
    whole = time.monotonic() - t

    class Stop(Exception):
        pass

    calls = []

    def callback(done, total):
        calls.append(done)
        raise Stop("from the callback")

    t = time.monotonic()
    with pytest.raises(Stop, match="from the callback"):
        udvr.build(data, quantiles=8, gmm=4, progress=callback)
    stopped = time.monotonic() - t
    assert len(calls) == 1
    # The build stops at its next progress step instead of running to the end.
    assert stopped < 0.5 * whole, (stopped, whole)


def test_ctrl_c_interrupts_a_long_render():
    code = textwrap.dedent("""
        import sys, time
        import numpy as np
        import udvr
        m = udvr.build(np.random.default_rng(0).random((8, 24, 24, 24), dtype=np.float32),
                       quantiles=0, gmm=2)
        print("rendering", flush=True)
        t = time.monotonic()
        try:
            udvr.render(m, "gmm-mc", size=256, realizations=10000, force=True)
            print("finished", flush=True)
        except KeyboardInterrupt:
            print(f"interrupted after {time.monotonic() - t:.2f} s", flush=True)
    """)
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, PYTHONPATH=str(BUILD / "python")))
    try:
        assert p.stdout.readline().strip() == "rendering"
        time.sleep(1.0)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=20)
    finally:
        if p.poll() is None:
            p.kill()
    assert out.startswith("interrupted after"), out + err
    assert float(out.split()[2]) < 5.0


def test_set_threads_is_clamped_and_checked():
    try:
        n = udvr.set_threads(10**9)
        assert 1 <= n <= 4 * os.cpu_count()
        assert udvr.set_threads(2) == 2
        with pytest.raises(ValueError, match="threads must be >= 0"):
            udvr.set_threads(-1)
    finally:
        udvr.set_threads(0)


def test_experiment_sizes_may_only_shrink(tmp_path):
    t = time.monotonic()
    with pytest.raises(ValueError, match="realizations 1000000000 is out of range"):
        udvr.experiment("tangle", quick=True, out=tmp_path, realizations=10**9)
    with pytest.raises(ValueError, match="image_size"):
        udvr.experiment("tangle", quick=True, out=tmp_path, image_size=100_000)
    assert time.monotonic() - t < 5


def test_experiment_output_folder_is_not_the_tf_folder(tmp_path):
    # A copy of the TFs: where the check is missing the experiment writes into the folder.
    tfs = tmp_path / "tf"
    shutil.copytree(pathlib.Path(__file__).resolve().parents[2] / "data" / "tf", tfs)
    before = sorted(p.name for p in tfs.iterdir())
    with pytest.raises(ValueError, match="is also an input"):
        udvr.experiment("tangle", quick=True, out=tfs, tf_dir=tfs)
    assert sorted(p.name for p in tfs.iterdir()) == before


def test_widget_raster_over_the_cap_needs_force():
    import json
    widgets = [{"type": "box", "rgba": [1, 0, 0, 1], "x": [0, 1], "y": [0, 1]}] * 64
    text = json.dumps({"domain": [0, 1, 0, 1], "widgets": widgets})
    with pytest.raises(ValueError, match="force"):
        udvr.TransferFunction2D.from_widgets(text, resolution=(2048, 2048))
    tf = udvr.TransferFunction2D.from_widgets(text, resolution=(64, 64))
    assert tf.raster.shape == (64, 64, 4)
