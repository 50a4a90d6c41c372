"""One description per option (render/render_options.h): the CLI's flags, the Python keywords
and `udvr serve`'s query keys come from the same tables, and a value is parsed and checked by the
same code wherever it is given."""
import urllib.parse

import numpy as np
import pytest

import golden
from serve_util import Server

udvr = pytest.importorskip("udvr")

MODEL = golden.GOLDEN / "model.vti"
TF = golden.GOLDEN / "tf.json"


def test_cli_help_lists_every_option():
    render_help = golden.udvr("render", "--help")
    probe_help = golden.udvr("probe", "--help")
    options = udvr.render_options()
    assert len(options) == 21
    for name, kind, default, value_range, help_text in options:
        flag = "--" + name.replace("_", "-")
        assert flag in render_help, flag
        assert help_text.split(" (")[0][:30] in " ".join(render_help.split()), name
        assert kind in ("text", "real", "whole", "flag")
        assert isinstance(default, {"text": str, "real": float, "whole": int, "flag": bool}[kind])
        assert (value_range is None) == (kind in ("text", "flag")), name
    assert "--uniform-width" in probe_help
    assert "--azimuth" not in probe_help  # probe takes the classification options only


def test_python_keywords_render_what_the_cli_flags_render(tmp_path):
    flags = ["--azimuth", "-40", "--elevation", "12.5", "--zoom", "1.4", "--early-exit", "0.7",
             "--background", "0.1,0.2,0.3", "--no-skip", "--uniform-width", "minmax",
             "--view-angle", "25", "--step", "0.2"]
    npy = tmp_path / "cli.npy"
    golden.udvr("render", MODEL, "--model", "uniform", "--tf", TF, "--size", "24x18", *flags,
                "--float", npy, "-o", tmp_path / "cli.png")
    got = udvr.render(udvr.load(str(MODEL)), "uniform", str(TF), (24, 18), azimuth=-40,
                      elevation=12.5, zoom=1.4, early_exit=0.7, background=(0.1, 0.2, 0.3),
                      no_skip=True, uniform_width="minmax", view_angle=25, step=0.2)
    np.testing.assert_array_equal(got, np.load(npy))
    # skip_empty is the old spelling of no_skip, and gives the same image
    old = udvr.render(udvr.load(str(MODEL)), "uniform", str(TF), (24, 18), azimuth=-40,
                      elevation=12.5, zoom=1.4, early_exit=0.7, background=(0.1, 0.2, 0.3),
                      skip_empty=False, uniform_width="minmax", view_angle=25, step=0.2)
    np.testing.assert_array_equal(old, got)


@pytest.mark.parametrize("name, value", [("zoom", "0"), ("elevation", "91"), ("seed", "-1"),
                                         ("realizations", "1.5"), ("uniform-width", "wide"),
                                         ("early-exit", "nan")])
def test_the_same_value_fails_the_same_way_everywhere(tmp_path, name, value):
    p = golden.subprocess.run([golden.binary(), "render", str(MODEL), "--tf", str(TF),
                               "--size", "8", "--" + name, value, "-o", str(tmp_path / "x.png")],
                              capture_output=True, text=True, env=dict(golden.os.environ,
                                                                       UDVR_NO_PROGRESS="1"))
    assert p.returncode == 2, p.stderr
    cli = p.stderr.strip().removeprefix("udvr: error: ")
    kw = {name.replace("-", "_"): value}
    with pytest.raises(ValueError) as err:
        udvr.render(udvr.load(str(MODEL)), "mean", str(TF), 8, **kw)
    # the same message, the option named as each front end spells it
    assert str(err.value).replace(name.replace("-", "_"), "--" + name) == cli, (str(err.value),
                                                                                 cli)
    assert not (tmp_path / "x.png").exists()


def test_the_server_takes_the_remote_options_by_their_names():
    s = Server(MODEL, "--tf", TF)
    try:
        names = [row[0].replace("_", "-") for row in udvr.render_options()]
        special = {"size": {"size": "8x6"}, "uniform-width": {"uniform-width": "std"},
                   "view": {"view": "+x"}, "frame": {"frame": "box"},
                   "background": {"background": "0,0,0"}}
        camera = {"position": "9,9,9", "focal-point": "0,0,0", "view-up": "0,0,1"}
        for name in names:
            query = {"size": "8x6"}
            query.update(camera if name in camera else special.get(name, {name: "1"}))
            status, _, body = s.get("/api/render?" + urllib.parse.urlencode(query))
            if name == "force":  # the CLI's alone: not a query key
                assert status == 400 and b"unknown parameter 'force'" in body, body
            else:
                assert status == 200, (name, status, body[:200])
        status, _, body = s.get("/api/render?size=8x6&zoom=0")
        assert status == 400 and b"zoom must lie in (0, 1000], got 0" in body, body
    finally:
        s.stop()


def test_unknown_keyword_names_the_options():
    with pytest.raises(TypeError, match="unexpected keyword argument 'azimut'.*azimuth"):
        udvr.render(udvr.load(str(MODEL)), "mean", str(TF), 8, azimut=3)


def test_python_takes_its_defaults_from_the_library():
    """Camera.default/framed, render() and probe() keep no default of their own (issue 31): each
    is the CLI's (SPEC §5's camera, 512x512, uniform width variance)."""
    box = (0.0, 2.0, 0.0, 1.0, 0.0, 3.0)
    spec = udvr.Camera.default(box, azimuth=30, elevation=20, zoom=1, view_angle=30)
    assert udvr.Camera.default(box).position == pytest.approx(spec.position, abs=1e-12)
    framed = udvr.Camera.framed(box, azimuth=30, elevation=20, zoom=1, view_angle=30)
    assert udvr.Camera.framed(box).position == pytest.approx(framed.position, abs=1e-12)
    axis = udvr.Camera.framed(box, "+x", azimuth=0, elevation=0)
    assert udvr.Camera.framed(box, "+x").position == pytest.approx(axis.position, abs=1e-12)
    model = udvr.load(str(MODEL))
    assert udvr.render(model, "mean", str(TF)).shape == (512, 512, 4)
    assert model.probe((1, 1, 1), "uniform", str(TF)) == \
        model.probe((1, 1, 1), "uniform", str(TF), uniform_width="variance")
    helps = {row[0]: row[-1] for row in udvr.render_options()}
    assert "(default 512x512)" in helps["size"] and "(default 30;" in helps["azimuth"]
    defaults = {row[0]: row[2] for row in udvr.render_options()}
    assert defaults["size"] == "512x512" and defaults["azimuth"] == 30.0
    assert defaults["realizations"] == 200 and defaults["uniform_width"] == "variance"


def test_probe_takes_the_classification_options_from_the_table():
    """Model.probe's keywords are udvr.probe_options() (the classification table, as `udvr
    probe`), each checked by the library: a new classification option reaches probe without a
    change in Python (issue 31)."""
    rows = udvr.probe_options()
    assert [row[0] for row in rows] == ["uniform_width"]
    assert rows[0][2] == "variance" and rows[0][3] is None
    assert set(row[0] for row in rows) <= set(row[0] for row in udvr.render_options())
    model = udvr.load(str(MODEL))
    variance = model.probe((1, 1, 1), "uniform", str(TF))
    assert model.probe((1, 1, 1), "uniform", str(TF), uniform_width="std") == variance
    assert model.probe((1, 1, 1), "uniform", str(TF), uniform_width=None) == variance
    minmax = model.probe((1, 1, 1), "uniform", str(TF), uniform_width="minmax")
    assert minmax["expected_rgba"] != variance["expected_rgba"]
    cli = golden.udvr("probe", MODEL, "--point", "1,1,1", "--model", "uniform", "--tf", TF,
                      "--uniform-width", "minmax", "--json")
    assert golden.json.loads(cli)["expected_rgba"] == pytest.approx(minmax["expected_rgba"],
                                                                    abs=1e-12)
    with pytest.raises(ValueError, match="must be 'variance'"):
        model.probe((1, 1, 1), "uniform", str(TF), uniform_width="wide")
    with pytest.raises(TypeError, match=r"probe\(\) got an unexpected keyword argument 'azimuth'"):
        model.probe((1, 1, 1), "uniform", str(TF), azimuth=3)  # a frame option: render's alone


def test_force_is_described_once_for_every_command():
    helps = [golden.udvr(cmd, "--help") for cmd in ("render", "probe", "serve")]
    lines = [next(line.strip() for line in h.splitlines() if line.strip().startswith("--force "))
             for h in helps]
    assert lines[0] == lines[1] == lines[2], lines
    assert "1e8 widget evaluations" in lines[0] and "10000" in lines[0]
