"""The ParaView plugin (issue 32, docs/paraview.md): it loads in pvbatch, links ParaView's VTK and
never Debian's, and examples/paraview/render.py's images match `udvr render`'s with the same
flags (RMSE of SPEC §6 ≤ 2/255) for every 1D model and a 2D TF, on one process and on two MPI
ranks that each render their piece of a 2-piece .pvti; bad inputs give ParaView errors, not
crashes. pvbatch runs under xvfb-run (Debian's ParaView is GLX only) and inside `timeout`.

Skipped where the build has no plugin (build/paraview_plugin.txt, written by CMake) unless
UDVR_PARAVIEW=ON (CI), where a missing plugin fails. UDVR_PARAVIEW_TEST_SEED picks the model's
noise (default 7)."""
import json
import os
import pathlib
import random
import re
import shutil
import subprocess

import pytest

from conftest import BUILD, ROOT, run_ok

PLUGIN_TXT = BUILD / "paraview_plugin.txt"
PVBATCH = BUILD / "paraview" / "udvr-pvbatch"
PVPYTHON = BUILD / "paraview" / "udvr-pvpython"
RENDER = ROOT / "examples" / "paraview" / "render.py"
BATCH = pathlib.Path(__file__).with_name("paraview_batch.py")
SEED = int(os.environ.get("UDVR_PARAVIEW_TEST_SEED", "7"))
SIZE = "96x96"
TOLERANCE = 2.0 / 255.0
# Every model with a 1D classification (members needs an ensemble, not a model file).
MODELS_1D = ["mean", "uniform", "uniform-fast", "uniform-exact", "gaussian", "gmm-ordered",
             "gmm-mc",
             "quantile-range", "quantile-mean", "quantile-mean-mass", "iqr", "quartile-lower",
             "quartile-middle", "quartile-upper"]

if not PLUGIN_TXT.is_file():
    if os.environ.get("UDVR_PARAVIEW") == "ON":
        raise RuntimeError("UDVR_PARAVIEW=ON but the build has no ParaView plugin "
                           "(%s is missing)" % PLUGIN_TXT)
    pytest.skip("the build has no ParaView plugin (see CMake's line on it)",
                allow_module_level=True)
PLUGIN = pathlib.Path(PLUGIN_TXT.read_text().strip())
for tool in ("xvfb-run", "timeout"):
    if shutil.which(tool) is None:
        raise RuntimeError("the ParaView tests need %s (scripts/setup.sh installs xvfb)" % tool)

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def pvbatch(*args, ranks=1, timeout=300, env=None, tool=PVBATCH):
    """pvbatch (udvr's launcher) under xvfb-run and `timeout`; ranks > 1 through mpirun. Xvfb runs
    with -noreset: by default it resets when its last client disconnects, and pvbatch, which
    closes its first connection and opens another, then sometimes finds no server ("bad X server
    connection", abort; 2 of 8 runs under load, 0 of 10 with -noreset). xvfb-run -a searches for
    a free display from a random number: runs on one machine share /tmp/.X*-lock."""
    cmd = ["timeout", str(timeout), "xvfb-run", "-a", "-n", str(random.randint(100, 30000)),
           "-s", "-screen 0 640x480x24 -noreset"]
    if ranks > 1:
        cmd += ["mpirun", "-np", str(ranks), "-x", "UDVR_PARAVIEW_VERBOSE"]
    cmd += [str(tool), *map(str, args)]
    e = dict(os.environ, UDVR_NO_PROGRESS="1", UDVR_PARAVIEW_VERBOSE="1", **MPI_ENV, **(env or {}))
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout + 30, env=e,
                          stdin=subprocess.DEVNULL)


def rmse(a, b):
    """SPEC §6's RMSE, from `udvr compare`."""
    return float(run_ok("compare", a, b).stdout.split()[0])


def write_tf(model, path, opacity):
    """The cool-to-warm preset over `model`'s percentiles as ParaView JSON (both sides read the
    file), its opacity replaced by `opacity`: (fraction of the preset's range, α) pairs."""
    run_ok("render", model, "--tf", "cool-to-warm", "--save-tf", path, "--size", "8x8",
           "-o", path.with_suffix(".png"))
    tf = json.loads(path.read_text())
    xs = tf[0]["Points"][0::4]
    lo, span = xs[0], xs[-1] - xs[0]
    tf[0]["Points"] = [v for f, a in opacity for v in (lo + f * span, a, 0.5, 0.0)]
    path.write_text(json.dumps(tf))


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """A random model (tangle with bimodal noise, seed SEED) as .vti and as a 2-piece .pvti, a TF
    and a 2D TF raster."""
    d = tmp_path_factory.mktemp("paraview")
    run_ok("generate", "tangle", "--dims", "24", "-o", d / "field.vti")
    run_ok("perturb", d / "field.vti", "--members", "16", "--noise", "bimodal", "--seed", SEED,
           "-o", d / "ensemble.nc")
    run_ok("build", d / "ensemble.nc", "--gmm", "3", "-o", d / "model.vti")
    run_ok("build", d / "ensemble.nc", "--gmm", "3", "-o", d / "model.pvti", "--pieces", "2")
    # Opacity in a band (a fuzzy isosurface), where the models' images differ by 5/255 or more.
    write_tf(d / "model.vti", d / "tf.json",
             [(0.0, 0.0), (0.3, 0.0), (0.35, 0.8), (0.4, 0.0), (1.0, 0.0)])
    run_ok("tf2", ROOT / "data" / "tf2" / "tangle.json", "--over", d / "model.vti",
           "-o", d / "tf2.vti")
    return d


def test_plugin_links_paraviews_vtk_and_not_debians():
    libs = subprocess.run(["ldd", str(PLUGIN)], capture_output=True, text=True,
                          check=True).stdout
    vtk = re.findall(r"libvtk\S+", libs)
    assert vtk, libs
    assert all("-pv5." in name for name in vtk), [n for n in vtk if "-pv5." not in n]


def test_plugin_loads_in_pvbatch(tmp_path):
    script = tmp_path / "load.py"
    script.write_text(
        "import os\n"
        "from paraview import servermanager\n"
        "from paraview.simple import LoadPlugin\n"
        "defs = servermanager.ProxyManager().SMProxyManager.GetProxyDefinitionManager()\n"
        "if not defs.HasDefinition('representations', 'UncertainVolumeRepresentation'):\n"
        "    LoadPlugin(os.environ['UDVR_PARAVIEW_PLUGIN'], remote=False, ns=globals())\n"
        "print('loaded', defs.HasDefinition('representations', 'UncertainVolumeRepresentation'))\n")
    r = pvbatch(script, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "loaded True" in r.stdout, r.stdout + r.stderr


def test_pvpython_loads_the_plugin_and_renders_like_the_cli(models):
    """udvr-pvpython: python3-paraview's pvpython (unpacked into the build tree where
    python3-vtk9 is installed, scripts/paraview_python.sh) with the plugin; render.py through it
    against `udvr render`."""
    pv, cli = models / "pvpython_qr.png", models / "cli_pvpython_qr.png"
    args = [models / "model.vti", "--model", "quantile-range", "--tf", models / "tf.json",
            "--size", SIZE]
    r = pvbatch(RENDER, *args, "-o", pv, timeout=240, tool=PVPYTHON)
    assert r.returncode == 0, r.stdout + r.stderr
    run_ok("render", *args, "-o", cli)
    e = rmse(pv, cli)
    print("pvpython quantile-range: RMSE %.5f" % e)
    assert e <= TOLERANCE


def cli_and_paraview_jobs(d, kinds, source, tag, extra=()):
    """(cli image, paraview image, cli args, render.py args) per model."""
    jobs = []
    for kind in kinds:
        cli, pv = d / f"cli_{tag}_{kind}.png", d / f"pv_{tag}_{kind}.png"
        args = [str(source), "--model", kind, *extra, "--size", SIZE, "--realizations", "20"]
        jobs.append((cli, pv, args))
    return jobs


def check_against_cli(d, jobs, ranks, log):
    (d / "jobs.json").write_text(json.dumps([[*a, "-o", str(pv)] for _, pv, a in jobs]))
    r = pvbatch(BATCH, d / "jobs.json", ranks=ranks, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "ERR|" not in r.stderr, r.stderr
    worst = 0.0
    for cli, pv, args in jobs:
        run_ok("render", *args, "-o", cli, timeout=300)
        e = rmse(pv, cli)
        log.append("%s %s: RMSE %.5f (%.2f/255)" % (ranks, args[2], e, 255 * e))
        worst = max(worst, e)
        assert e <= TOLERANCE, "%s on %d rank(s): RMSE %.5f > 2/255" % (args[2], ranks, e)
    print("\n".join(log))
    return r


def test_every_1d_model_matches_the_cli_on_one_process(models):
    check_against_cli(models, cli_and_paraview_jobs(
        models, MODELS_1D, models / "model.vti", "1", ["--tf", str(models / "tf.json")]), 1, [])
    # The model property reaches the ray caster: the models' images differ far more than 2/255.
    for kind in ("gaussian", "quantile-range", "gmm-mc", "quartile-upper"):
        assert rmse(models / f"pv_1_{kind}.png", models / "pv_1_mean.png") > 2 * TOLERANCE, kind


def test_a_2d_tf_matches_the_cli(models):
    """A raster .vti and a widget .json (rasterised by udvr's core inside ParaView), each against
    `udvr render --tf2` with the same file; the widget file's image is its raster's."""
    widgets = ROOT / "data" / "tf2" / "tangle.json"
    check_against_cli(models, cli_and_paraview_jobs(
        models, ["quantile-range", "mean"], models / "model.vti", "2d",
        ["--tf2", str(models / "tf2.vti")]) + cli_and_paraview_jobs(
        models, ["quantile-range", "mean"], models / "model.vti", "2dj",
        ["--tf2", str(widgets)]), 1, [])
    assert rmse(models / "pv_2dj_quantile-range.png", models / "pv_2d_quantile-range.png") <= 1e-6


def test_a_bad_widget_file_is_a_paraview_error(models, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"domain": [0, 1, 0, 1], "widgets": [{"type": "box", "x": [0, 1]}]}')
    r = pvbatch(RENDER, models / "model.vti", "--tf2", bad, "--size", "16x16", "-o",
                tmp_path / "x.png", timeout=120)
    assert "ERR|" in r.stderr, r.stdout + r.stderr
    assert "bad.json: widget 0" in r.stderr.split("ERR|", 1)[1], r.stderr


def test_two_ranks_render_their_pieces_and_match_the_cli(models):
    # Every 1D model and a 2D TF in one mpirun. gmm-mc across ranks is an approximation (each
    # rank averages its realizations before compositing) and 2D TFs differentiate each piece's
    # own grid (one-sided at the shared plane); both stay well within 2/255 here.
    jobs = cli_and_paraview_jobs(models, MODELS_1D, models / "model.pvti", "mpi",
                                 ["--tf", str(models / "tf.json")])
    jobs += cli_and_paraview_jobs(models, ["quantile-range"], models / "model.pvti", "mpi2d",
                                  ["--tf2", str(models / "tf2.vti")])
    r = check_against_cli(models, jobs, 2, [])
    # Each rank rendered its own piece (z 0..11 and 11..23 of the 24 planes), not the whole.
    extents = set(re.findall(r"udvr: rendering extent (\S+ \S+ \S+) of", r.stderr))
    assert extents == {"0..23 0..23 0..11", "0..23 0..23 11..23"}, r.stderr


def test_two_ranks_each_hold_half_of_a_pvti_model(models, tmp_path):
    """A 2-piece .pvti of a 128³ model (27 floats a voxel, 216 MiB) on 2 ranks, read by the
    plugin's .pvti reader: each rank's VmRSS grows by less than 0.7 × the model (its half, 108
    MiB, and the reader's buffers; measured +119/+119 MiB). ParaView's own reader, in the same
    processes, adds a whole model's worth a rank (its piece readers keep a second copy; measured
    +216/+220), so the check tells the two apart. Jobs in one pvbatch, told apart by frame size:
    16² the 24³ model (baseline), 32² the big model through udvr's reader, 48² through ParaView's."""
    big = tmp_path / "big.pvti"
    run_ok("generate", "tangle", "--dims", "128", "-o", tmp_path / "f.vti")
    run_ok("perturb", tmp_path / "f.vti", "--members", "8", "--noise", "gaussian", "--seed",
           SEED, "-o", tmp_path / "e.nc")
    run_ok("build", tmp_path / "e.nc", "--pieces", "2", "-o", big, timeout=300)
    model_mib = 128 ** 3 * (4 + 9 + 2 + 12) * 4 / 2 ** 20
    jobs = [[str(models / "model.pvti"), "--size", "16x16", "-o", str(tmp_path / "a.png")],
            [str(big), "--size", "32x32", "-o", str(tmp_path / "b.png")],
            [str(big), "--size", "48x48", "--pvti-reader", "paraview",
             "-o", str(tmp_path / "c.png")]]
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    r = pvbatch(BATCH, tmp_path / "jobs.json", ranks=2, timeout=300)
    assert r.returncode == 0 and "ERR|" not in r.stderr, r.stdout + r.stderr
    rss = {}  # pid -> frame side -> largest VmRSS, MiB
    for pid, side, mib in re.findall(r"udvr: pid (\d+) frame (\d+)x\d+ .*VmRSS (\d+) MiB",
                                     r.stderr):
        per = rss.setdefault(pid, {})
        per[side] = max(per.get(side, 0), int(mib))
    assert len(rss) == 2 and all(len(p) == 3 for p in rss.values()), r.stderr
    for pid, p in rss.items():
        udvr_reader, paraview_reader = p["32"] - p["16"], p["48"] - p["32"]
        print("rank pid %s: baseline %d MiB, udvr reader +%d, ParaView's reader +%d; model %.0f"
              % (pid, p["16"], udvr_reader, paraview_reader, model_mib))
        assert udvr_reader < 0.7 * model_mib, (pid, p)
        assert paraview_reader > 0.7 * model_mib, (pid, p)


CT = ROOT.parent / "shared" / "data" / "chest-ct" / "chest.nhdr"


@pytest.mark.skipif(not CT.is_file(), reason="../shared/data/chest-ct is absent")
def test_a_real_ct_reduced_by_bricks_matches_the_cli(tmp_path):
    """The chest CT reduced by 4³ bricks: a model whose full-resolution bounds exceed its grid's
    box (the camera and the pieces' outer faces use the bounds), anisotropic spacing."""
    run_ok("build", CT, "--downsample", "4", "--gmm", "0", "-o", tmp_path / "ct.vti", timeout=300)
    run_ok("build", CT, "--downsample", "4", "--gmm", "0", "--pieces", "2",
           "-o", tmp_path / "ct.pvti", timeout=300)
    write_tf(tmp_path / "ct.vti", tmp_path / "tf.json",
             [(0.0, 0.0), (0.45, 0.0), (0.6, 0.5), (0.75, 0.0), (1.0, 0.9)])
    extra = ["--tf", str(tmp_path / "tf.json")]
    check_against_cli(tmp_path, cli_and_paraview_jobs(
        tmp_path, ["mean", "gaussian", "quantile-range"], tmp_path / "ct.vti", "ct1", extra), 1, [])
    check_against_cli(tmp_path, cli_and_paraview_jobs(
        tmp_path, ["mean", "quantile-range"], tmp_path / "ct.pvti", "ct2", extra), 2, [])


def test_paraviews_own_2d_tf_is_udvrs_2d_classification(models, tmp_path):
    """ParaView 5.11's 2D TF (a box over value x gradient magnitude, UseTransfer2D) classifies
    with udvr's 2D kernels: the image equals `udvr render --tf2` with ParaView's raster (written
    out by the script, texel centres as VTK's GPU mapper samples them)."""
    script = tmp_path / "tf2.py"
    script.write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(RENDER.parent)!r})\n"
        "import render\n"
        "from paraview.simple import *\n"
        "from vtkmodules.vtkCommonDataModel import vtkImageData\n"
        "from vtkmodules.vtkIOXML import vtkXMLImageDataWriter\n"
        f"view, d = render.main([{str(models / 'model.vti')!r}, '--model', 'quantile-range', '--tf',\n"
        f"             {str(models / 'tf.json')!r}, '--size', '{SIZE}', '-o', {str(tmp_path / 'pv1d.png')!r}])\n"
        "tf2 = GetTransferFunction2D('mean')\n"
        "tf2.AutomaticRescaleRangeMode = 'Never'\n"
        "tf2.Range = [-7.0, 40.0, 0.0, 90.0]\n"
        "tf2.OutputDimensions = [48, 40]\n"
        "tf2.Boxes = [4.0, 0.0, 12.0, 45.0, 0.9, 0.2, 0.1, 0.4]\n"
        "d.TransferFunction2D = tf2\n"
        "d.UseTransfer2D = 1\n"
        f"SaveScreenshot({str(tmp_path / 'pv.png')!r}, view, ImageResolution=[{SIZE.replace('x', ', ')}])\n"
        "img = tf2.GetClientSideObject().GetFunction()\n"
        "rg = tf2.GetClientSideObject().GetRange()\n"
        "dims = img.GetDimensions()\n"
        "out = vtkImageData()\n"
        "out.DeepCopy(img)\n"
        "dx, dy = (rg[1] - rg[0]) / dims[0], (rg[3] - rg[2]) / dims[1]\n"
        "out.SetOrigin(rg[0] + dx / 2, rg[2] + dy / 2, 0)\n"
        "out.SetSpacing(dx, dy, 1)\n"
        "w = vtkXMLImageDataWriter()\n"
        f"w.SetFileName({str(tmp_path / 'raster.vti')!r})\n"
        "w.SetInputData(out)\n"
        "w.Write()\n")
    r = pvbatch(script, timeout=180)
    assert r.returncode == 0 and "ERR|" not in r.stderr, r.stdout + r.stderr
    run_ok("render", models / "model.vti", "--model", "quantile-range", "--tf2",
           tmp_path / "raster.vti", "--size", SIZE, "-o", tmp_path / "cli.png", timeout=300)
    e = rmse(tmp_path / "pv.png", tmp_path / "cli.png")
    print("ParaView's 2D TF: RMSE %.5f (%.2f/255)" % (e, 255 * e))
    assert e <= TOLERANCE
    assert rmse(tmp_path / "pv.png", tmp_path / "pv1d.png") > 10 * TOLERANCE  # not the 1D TF


def field_data(path):
    """A model file's field data (SPEC §7) as {name: [values as text]}, read by VTK (python3-vtk9,
    which udvr's build needs), and its grid (origin, spacing, whole extent)."""
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLPImageDataReader
    r = vtkXMLPImageDataReader() if str(path).endswith(".pvti") else vtkXMLImageDataReader()
    r.SetFileName(str(path))
    r.Update()
    out = r.GetOutput()
    fd = out.GetFieldData()
    values = {}
    for i in range(fd.GetNumberOfArrays()):
        a = fd.GetAbstractArray(i)
        values[a.GetName()] = [a.GetVariantValue(j).ToString() for j in range(a.GetNumberOfValues())]
    return values, (out.GetOrigin(), out.GetSpacing(), out.GetExtent())


def assert_same_model(pv_path, cli_path, samples, field=False):
    """The Build Model filter's model file equals `udvr build`'s, array for array, bit for bit;
    with `field`, also its grid and every field datum (default_tf too) but `source`, which names
    the input (ParaView's arrays vs the CLI's files)."""
    import numpy as np
    import udvr
    pv, cli = udvr.load(pv_path), udvr.load(cli_path)
    for name in ("mean", "stddev", "min", "max", "quantiles", "iqr", "gmm"):
        a, b = np.asarray(getattr(pv, name)), np.asarray(getattr(cli, name))
        assert a.shape == b.shape and (a.size > 0 or name == "gmm"), name
        assert np.array_equal(a, b), (name, float(np.max(np.abs(a - b))))
    assert list(pv.bounds) == list(cli.bounds) and pv.samples_per_voxel == samples
    if field:
        (fa, grid_a), (fb, grid_b) = field_data(pv_path), field_data(cli_path)
        assert grid_a == grid_b, (grid_a, grid_b)
        fa.pop("source")
        fb.pop("source")
        assert fa == fb, {k: (fa.get(k), fb.get(k)) for k in set(fa) | set(fb)
                          if fa.get(k) != fb.get(k)}
        return fa


CT_SMALL = ROOT.parent / "shared" / "data" / "tooth" / "tooth.nhdr"  # 103x94x161 uint8 CT


def test_build_model_filter_matches_udvr_build(tmp_path):
    """udvr Build Model, with `udvr build`'s options as properties, gives `udvr build`'s model of
    the same input, array for array and field datum for field datum, bit for bit: member files
    (NRRD) joined by ParaView's Append Attributes, with the defaults and with kde + Scott's
    bandwidth + uneven quantile levels + tail ε; and (where ../shared has it) a real CT, the
    tooth, by 4³ bricks (Downsample): the defaults (kde, Silverman; default_tf of the whole
    field), a bandwidth h = 2.5 + GMM 2 + NaN skip, and dequantized. Bad properties are ParaView
    errors naming the property. One pvbatch."""
    import numpy as np
    rng = np.random.default_rng(SEED)
    z, y, x = np.mgrid[0:9, 0:10, 0:12].astype(np.float32)
    base = np.sin(x / 3) + np.cos(y / 4) * z / 5
    (tmp_path / "members").mkdir()
    for i in range(8):
        member = base + rng.normal(0, 0.3, base.shape) + (rng.random(base.shape) < 0.2) * 1.5
        member.astype("<f4").tofile(tmp_path / "members" / f"m_{i}.raw")
        (tmp_path / "members" / f"m_{i}.nhdr").write_text(
            "NRRD0004\ntype: float\ndimension: 3\nsizes: 12 10 9\nendian: little\n"
            "encoding: raw\nspace origin: (1,2,3)\n"
            f"space directions: (0.5,0,0) (0,0.5,0) (0,0,0.7)\ndata file: m_{i}.raw\n")
    members = tmp_path / "members" / "m_*.nhdr"
    kde = ["--density", "kde", "--bandwidth", "scott", "--quantile-levels", "0,0.1,0.5,0.9,1",
           "--tail-eps", "0.02"]
    # (CLI flags, the filter's properties, input) per case; None: the member files.
    cases = {"default": ([], "", None),
             "kde": (kde, "Density='kde', Bandwidth='scott', QuantileLevels='0,0.1,0.5,0.9,1', "
                     "TailEps=0.02", None)}
    if CT_SMALL.is_file():
        cases["ct"] = (["--downsample", "4"], "Downsample=4", CT_SMALL)
        cases["ct_h"] = (["--downsample", "4", "--bandwidth", "2.5", "--gmm", "2", "--nan", "skip"],
                         "Downsample=4, Bandwidth='2.5', GmmComponents=2, NanPolicy='skip'",
                         CT_SMALL)
        cases["ct_deq"] = (["--downsample", "4", "--density", "dequantized", "--gmm", "0"],
                           "Downsample=4, Density='dequantized', GmmComponents=0", CT_SMALL)
    lines = ["import glob", "from paraview.simple import *",
             f"files = sorted(glob.glob({str(members)!r}))",
             "joined = AppendAttributes(Input=[OpenDataFile(f) for f in files])"]
    if CT_SMALL.is_file():
        lines.append(f"ct = OpenDataFile({str(CT_SMALL)!r})")
    for name, (flags, props, source) in cases.items():
        run_ok("build", source or members, *flags, "-o", tmp_path / f"cli_{name}.vti",
               timeout=300)
        lines.append(f"SaveData({str(tmp_path / f'pv_{name}.vti')!r}, proxy=udvrBuildModel("
                     f"Input={'ct' if source else 'joined'}{', ' + props if props else ''}))")
    # Bad inputs: each a ParaView error, not a crash (the script goes on).
    bad = {"few": ("OpenDataFile(files[0])", "", "at least 2 members"),
           "bandwidth": ("joined", "Density='kde', Bandwidth='wide'", "wide"),
           "levels": ("joined", "QuantileLevels='0,0.5,0.4,1'", "quantile"),
           "dequantized": ("joined", "Density='dequantized'", "integer-typed"),
           "bricks": ("joined", "Downsample=11", "--downsample 11 is larger than the grid")}
    for name, (source, props, _) in bad.items():
        lines += [f"m = udvrBuildModel(Input={source}{', ' + props if props else ''})",
                  "m.UpdatePipeline()", f"print('UPDATED {name}', flush=True)"]
    script = tmp_path / "build.py"
    script.write_text("\n".join(lines) + "\n")
    r = pvbatch(script, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    errors = [line for line in r.stderr.splitlines() if "ERR|" in line and "udvr:" in line]
    for name, (_, _, message) in bad.items():
        assert "UPDATED " + name in r.stdout, r.stdout + r.stderr
        assert any(message in line for line in errors), (name, errors)
    assert len(errors) == len(bad), errors  # the good cases gave none
    for name in cases:
        fd = assert_same_model(tmp_path / f"pv_{name}.vti", tmp_path / f"cli_{name}.vti",
                               64 if name.startswith("ct") else 8, field=True)
        if name == "ct":
            assert "default_tf" in fd and fd["bandwidth_rule"] == ["silverman"], fd
        if name == "kde":
            assert fd["bandwidth_rule"] == ["scott"] and fd["density"] == ["kde"], fd


FUEL = ROOT.parent / "shared" / "data" / "fuel-ensemble" / "fuel_ensemble.nc"


def test_netcdf_ensemble_reader_and_build_model_give_udvr_builds_model(models, tmp_path):
    """File → Open (OpenDataFile) of an ensemble NetCDF (`tangle(member, z, y, x)` from `udvr
    perturb`) picks the plugin's reader; it, then udvr Build Model, gives `udvr build
    ensemble.nc`'s model array for array, bit for bit (on 3 MPI ranks:
    test_three_ranks_build_and_render_their_pieces). Bad files in the same pvbatch: ParaView
    errors, not crashes."""
    import numpy as np
    import scipy.io
    ensemble = models / "ensemble.nc"
    data = ensemble.read_bytes()
    (tmp_path / "cut.nc").write_bytes(data[:-1])  # one byte short: netCDF-C would read zeros
    (tmp_path / "half.nc").write_bytes(data[:len(data) // 2])
    with scipy.io.netcdf_file(tmp_path / "rank3.nc", "w") as f:  # member, y, x: 2 grid dims
        f.createDimension("member", 4)
        f.createDimension("y", 5)
        f.createDimension("x", 6)
        f.createVariable("v", "f4", ("member", "y", "x"))[:] = np.ones((4, 5, 6), np.float32)
    run_ok("generate", "tangle", "--dims", "8", "-o", tmp_path / "field.nc")
    bad = {"cut.nc": "the file is cut short", "half.nc": "the file is cut short",
           "rank3.nc": "no variable with a member dimension",
           "field.nc": "no variable with a member dimension"}
    # A real NetCDF-4 (HDF5) ensemble where ../shared has it: built as `udvr build` does it, and
    # cut short: HDF5's own error.
    fuel = FUEL.is_file()
    if fuel:
        run_ok("build", FUEL, "-o", tmp_path / "fuel_cli.vti", timeout=300)
        (tmp_path / "fuel_cut.nc").write_bytes(FUEL.read_bytes()[:-100])
        bad["fuel_cut.nc"] = "cannot open as NetCDF: NetCDF: HDF error"
    script = tmp_path / "nc.py"
    script.write_text(
        "from paraview.simple import *\n"
        f"reader = OpenDataFile({str(ensemble)!r})\n"
        "print('OPENED WITH', reader.GetXMLName())\n"
        "model = udvrBuildModel(Input=reader, GmmComponents=3)\n"
        f"SaveData({str(tmp_path / 'pv.vti')!r}, proxy=model)\n"
        + (f"SaveData({str(tmp_path / 'fuel_pv.vti')!r}, proxy=udvrBuildModel("
           f"Input=OpenDataFile({str(FUEL)!r})))\n" if fuel else "") +
        "pd = reader.PointData\n"
        "names = [pd.GetArray(i).GetName() for i in range(pd.GetNumberOfArrays())]\n"
        "print('ARRAYS', ' '.join(names))\n"
        f"for name in {sorted(bad)!r}:\n"
        f"    r = udvrNetCDFEnsembleReader(FileName={str(tmp_path)!r} + '/' + name)\n"
        "    r.UpdatePipeline()\n"
        "    print('READ', name, r.GetDataInformation().GetNumberOfPoints())\n")
    r = pvbatch(script, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "OPENED WITH EnsembleNetCDFReader" in r.stdout, r.stdout  # before ParaView's own
    assert re.search(r"ARRAYS tangle_000 tangle_001 .* tangle_015\n", r.stdout), r.stdout
    assert_same_model(tmp_path / "pv.vti", models / "model.vti", 16)
    if fuel:
        assert_same_model(tmp_path / "fuel_pv.vti", tmp_path / "fuel_cli.vti", 10)
    errors = [line for line in r.stderr.splitlines() if "ERR|" in line]
    for name, message in bad.items():
        assert "READ %s 0" % name in r.stdout, r.stdout + r.stderr
        assert any(name + ": " + message in line for line in errors), (name, r.stderr)


def test_three_ranks_build_and_render_their_pieces(models, tmp_path):
    """One `mpirun -np 3 pvbatch`: (1) the NetCDF reader + Build Model, each rank building its
    third (whole x-y planes: the GMM's streams keyed by the whole grid's voxel index, the σ floor
    from the range reduced over the ranks) = `udvr build ensemble.nc` bit for bit; the tooth CT
    (where ../shared has it) by 4³ bricks with Scott's bandwidth and GMM 2 = `udvr build
    --downsample 4` bit for bit (each rank reads the 4 input planes of its model planes); (2) a
    3-piece .pvti rendered by render.py, each rank its piece, within 2/255 of `udvr render`."""
    ensemble = models / "ensemble.nc"
    run_ok("build", ensemble, "--gmm", "3", "--pieces", "3", "-o", tmp_path / "m3.pvti")
    ct = CT_SMALL.is_file()
    ct_flags = ["--downsample", "4", "--bandwidth", "scott", "--gmm", "2"]
    if ct:
        run_ok("build", CT_SMALL, *ct_flags, "-o", tmp_path / "ct_cli.vti", timeout=300)
    jobs = cli_and_paraview_jobs(tmp_path, ["mean", "quantile-range", "gmm-mc"],
                                 tmp_path / "m3.pvti", "np3", ["--tf", str(models / "tf.json")])
    jobs += cli_and_paraview_jobs(tmp_path, ["quantile-range"], tmp_path / "m3.pvti", "np3_2d",
                                  ["--tf2", str(models / "tf2.vti")])
    (tmp_path / "jobs.json").write_text(json.dumps([[*a, "-o", str(pv)] for _, pv, a in jobs]))
    (tmp_path / "mpi.py").write_text(
        "import json, sys\n"
        f"sys.path.insert(0, {str(RENDER.parent)!r})\n"
        "import render\n"
        "from paraview.simple import *\n"
        f"model = udvrBuildModel(Input=OpenDataFile({str(ensemble)!r}), GmmComponents=3)\n"
        f"SaveData({str(tmp_path / 'pv3.pvti')!r}, proxy=model)\n"
        + (f"ct = udvrBuildModel(Input=OpenDataFile({str(CT_SMALL)!r}), Downsample=4, "
           "Bandwidth='scott', GmmComponents=2)\n"
           f"SaveData({str(tmp_path / 'ct_pv.pvti')!r}, proxy=ct)\n" if ct else "") +
        f"for args in json.load(open({str(tmp_path / 'jobs.json')!r})):\n"
        "    render.main(args)\n"
        # Build Model straight into the representation, no file between: render.py opens the
        # ensemble through OpenDataFile, here the filter over ParaView's reader of it.
        "import paraview.simple as ps\n"
        "opened = ps.OpenDataFile\n"
        "def built(path, **kw):\n"
        "    m = ps.udvrBuildModel(Input=opened(path), GmmComponents=3)\n"
        "    object.__setattr__(m, 'PointArrayStatus', None)  # render.py's field-data reader\n"
        "    return m\n"
        "ps.OpenDataFile = built\n"
        f"render.main([{str(ensemble)!r}, '--model', 'quantile-range', '--tf',\n"
        f"             {str(models / 'tf.json')!r}, '--size', '{SIZE}', '--realizations', '20',\n"
        f"             '-o', {str(tmp_path / 'direct.png')!r}])\n")
    r = pvbatch(tmp_path / "mpi.py", ranks=3, timeout=600)
    assert r.returncode == 0 and "ERR|" not in r.stderr, r.stdout + r.stderr
    assert len(re.findall(r"<Piece ", (tmp_path / "pv3.pvti").read_text())) == 3
    assert_same_model(tmp_path / "pv3.pvti", models / "model.vti", 16)
    if ct:
        assert len(re.findall(r"<Piece ", (tmp_path / "ct_pv.pvti").read_text())) == 3
        assert_same_model(tmp_path / "ct_pv.pvti", tmp_path / "ct_cli.vti", 64)
    log = []
    for cli, pv, args in jobs:
        run_ok("render", *args, "-o", cli, timeout=300)
        e = rmse(pv, cli)
        log.append("3 ranks %s %s: RMSE %.5f (%.2f/255)" % (args[2], args[3], e, 255 * e))
        assert e <= TOLERANCE, log[-1]
    e = rmse(tmp_path / "direct.png", tmp_path / "cli_np3_quantile-range.png")
    log.append("3 ranks, Build Model straight into the representation: RMSE %.5f" % e)
    assert e <= TOLERANCE, log[-1]
    print("\n".join(log))
    # Each rank rendered its own third, not the whole. ParaView's representation splits the
    # .pvti over 3 ranks as its extent translator does, not as the file's 3 z-pieces: measured
    # z 0..7; y 0..11 and 11..23 of z 7..23 (those two ranks each read 2 of the 3 piece files).
    # Build Model's own pieces are z-slabs sharing their boundary plane: 0..7, 7..15, 15..23.
    found = re.findall(r"udvr: rendering extent (\S+ \S+ \S+) of \S+ \S+ \S+ \((\d+) voxels",
                       r.stderr)
    extents = {e for e, _ in found}
    assert {"0..23 0..23 0..7", "0..23 0..23 7..15", "0..23 0..23 15..23"} <= extents, extents
    assert len(extents) == 5 and all(int(v) < 24 ** 3 / 2 for _, v in found), set(found)


def bad_input_script(tmp_path, source, array, kind="mean"):
    script = tmp_path / "bad.py"
    script.write_text(
        "import os\n"
        "from paraview import servermanager\n"
        "from paraview.simple import *\n"
        "defs = servermanager.ProxyManager().SMProxyManager.GetProxyDefinitionManager()\n"
        "if not defs.HasDefinition('representations', 'UncertainVolumeRepresentation'):\n"
        "    LoadPlugin(os.environ['UDVR_PARAVIEW_PLUGIN'], remote=False, ns=globals())\n"
        f"r = OpenDataFile({str(source)!r})\n"
        "v = CreateView('RenderView')\n"
        "v.ViewSize = [64, 64]\n"
        "d = Show(r, v)\n"
        "d.SetRepresentationType('Uncertain Volume')\n"
        f"ColorBy(d, ('POINTS', {array!r}))\n"
        f"d.UncertainModel = {kind!r}\n"
        "Render(v)\n"
        "print('rendered')\n")
    return script


def test_a_non_model_array_is_a_paraview_error_not_a_crash(models, tmp_path):
    r = pvbatch(bad_input_script(tmp_path, models / "field.vti", "tangle"), timeout=120)
    assert r.returncode == 0 and "rendered" in r.stdout, r.stdout + r.stderr
    assert "ERR|" in r.stderr and "colour by one of its arrays" in r.stderr, r.stderr


def test_a_model_without_the_arrays_of_its_model_is_a_paraview_error(models, tmp_path):
    run_ok("build", models / "ensemble.nc", "--gmm", "0", "-o", tmp_path / "nogmm.vti")
    r = pvbatch(bad_input_script(tmp_path, tmp_path / "nogmm.vti", "mean", "gmm-ordered"),
                timeout=120)
    assert r.returncode == 0 and "rendered" in r.stdout, r.stdout + r.stderr
    assert "ERR|" in r.stderr and "gmm" in r.stderr.split("ERR|", 1)[1], r.stderr


def test_render_py_errors_are_one_line(models, tmp_path):
    r = pvbatch(RENDER, tmp_path / "missing.vti", "-o", tmp_path / "x.png", timeout=120)
    assert r.returncode == 1 and "render.py: cannot read" in r.stderr and "missing.vti" in r.stderr
    assert not (tmp_path / "x.png").exists()
    r = pvbatch(RENDER, models / "field.vti", "--tf", models / "tf.json", "-o",
                tmp_path / "x.png", timeout=120)
    assert r.returncode == 1 and "is not a udvr model" in r.stderr, r.stderr
    assert not (tmp_path / "x.png").exists()
