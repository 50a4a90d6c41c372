"""`udvr serve`'s HTTP API against the CLI: /api/render's PNG is `udvr render`'s for the same flags,
/api/probe's JSON is `udvr probe --json`'s, the diff and RMSE are `udvr compare`'s; bad requests
get a 4xx with a message and the server keeps serving; a burst of requests leaves no backlog."""
import concurrent.futures
import json
import re
import urllib.parse

import numpy as np
import pytest

from conftest import ROOT, assert_one_line_error, run_ok, run_udvr
from serve_util import (Server, cli_probe, cli_render, make_inputs, png_pixels, tf2_at,
                        tf2_raster)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("serve_api"))


@pytest.fixture(scope="module")
def server(inputs):
    s = Server(inputs.model, "--tf", inputs.tf, "--truth", inputs.truth)
    yield s
    s.stop()


def render(server, **params):
    status, headers, body = server.get("/api/render?" + urllib.parse.urlencode(params))
    assert status == 200, body[:300]
    return png_pixels(body), headers


def flags_of(params):
    out = []
    for k, v in params.items():
        out += [f"--{k}", str(v)]
    return out


@pytest.mark.parametrize("params", [
    {"model": "quantile-mean", "size": "96x64", "azimuth": 40, "elevation": -15, "zoom": 1.3},
    {"model": "gaussian", "size": "64x64"},
    {"model": "quartile-upper", "size": "48x48", "azimuth": 200},
    {"model": "uniform", "size": "64x48", "position": "6,2,5", "focal-point": "0.1,0,0",
     "view-up": "0,0,1", "view-angle": 40},
    {"model": "gmm-ordered", "size": "40x40", "parallel-scale": 3, "step": 0.05},
    {"model": "gmm-mc", "size": "32x32", "realizations": 5, "seed": 4},
    {"model": "mean", "size": "48x48", "view": "+x", "frame": "box"},
])
def test_render_is_the_cli_image(server, inputs, tmp_path, params):
    page, headers = render(server, **params)
    cli = cli_render(inputs, tmp_path / "cli.png", "--tf", inputs.tf, *flags_of(params))
    assert page.shape == cli.shape
    assert np.array_equal(page, cli)
    assert float(headers["X-Udvr-Render-Ms"]) >= 0


def test_rgba_format_is_the_pngs_values(server):
    """format=rgba (what the page asks for): the PNG's 8-bit RGBA values, rows from the top."""
    params = {"model": "quantile-range", "size": "80x48", "azimuth": 70}
    png, _ = render(server, **params)
    status, headers, body = server.get("/api/render?" + urllib.parse.urlencode(
        {**params, "format": "rgba"}))
    assert status == 200 and headers["Content-Type"] == "application/octet-stream"
    assert (int(headers["X-Udvr-Width"]), int(headers["X-Udvr-Height"])) == (80, 48)
    assert np.array_equal(np.frombuffer(body, np.uint8).reshape(48, 80, 4), png)


def test_truth_diff_and_rmse_are_compares(server, inputs, tmp_path):
    params = {"model": "quantile-range", "size": "64x64", "azimuth": 10}
    truth, _ = render(server, source="truth", **params)
    diff, headers = render(server, source="diff", **params)
    flags = ["--tf", inputs.tf, *flags_of({k: v for k, v in params.items() if k != "model"})]
    cli_render(inputs, tmp_path / "m.png", "--model", "quantile-range", *flags)
    cli_truth = cli_render(inputs, tmp_path / "t.png", "--model", "mean", *flags,
                           model_file=inputs.truth)
    assert np.array_equal(truth, cli_truth)
    out = run_ok("compare", tmp_path / "m.png", tmp_path / "t.png", "--diff", tmp_path / "d.png")
    assert float(headers["X-Udvr-Rmse"]) == pytest.approx(float(out.stdout), abs=1e-8)
    # compare --diff adds its colour scale on the right (rows up to 64 for the labels).
    h, w = diff.shape[:2]
    assert np.array_equal(diff, png_pixels(tmp_path / "d.png")[:h, :w])


def test_posted_tf_renders_and_reads_back(server, inputs, tmp_path):
    tf = [{"RGBPoints": [-5, 0.1, 0.2, 0.9, 10, 0.9, 0.8, 0.1, 30, 1, 0, 0],
           "Points": [-5, 0, 0.5, 0, 4, 0.05, 0.5, 0, 12, 0.6, 0.5, 0, 30, 0.2, 0.5, 0]}]
    try:
        assert server.json("/api/tf", data=json.dumps(tf).encode(), method="POST")["tf_version"] > 1
        back = server.json("/api/tf")
        assert back[0]["RGBPoints"] == tf[0]["RGBPoints"]
        assert back[0]["Points"] == tf[0]["Points"]
        (tmp_path / "tf.json").write_text(json.dumps(back))
        page, _ = render(server, model="iqr", size="64x64")
        cli = cli_render(inputs, tmp_path / "c.png", "--tf", tmp_path / "tf.json", "--model", "iqr",
                         "--size", "64x64")
        assert np.array_equal(page, cli)
    finally:
        server.get("/api/tf", data=inputs.tf.read_bytes(), method="POST")


@pytest.mark.parametrize("model", ["quantile-range", "gaussian", "gmm-ordered", "uniform"])
def test_probe_under_a_pixel_is_the_cli_probe(server, inputs, model):
    hit = server.json(f"/api/probe?model={model}&size=64x64&azimuth=30&x=32&y=30")
    # The first visible sample: E[alpha] there is at least 1 % of the ray's largest.
    assert hit["expected_rgba"][3] > 0
    assert hit == cli_probe(inputs.model, inputs.tf, model, hit["point"])
    again = server.json(f"/api/probe?model={model}&point=" + ",".join(map(repr, hit["point"])))
    assert again == hit


def test_probe_of_an_empty_pixel_says_so(server):
    status, _, body = server.get("/api/probe?size=64x64&x=0&y=0")
    assert status == 404 and "no visible sample" in json.loads(body)["error"]


def test_histogram_counts_every_voxel(server):
    h = server.json("/api/histogram?bins=50")
    assert len(h["counts"]) == 50 and sum(h["counts"]) == 32 ** 3
    assert h["lo"] < h["hi"] and h["below"] == 0 and h["above"] == 0


def test_state_lists_every_model(server):
    state = server.json("/api/state")
    names = [m["name"] for m in state["models"]]
    assert names[:12] == ["mean", "uniform", "gaussian", "gmm-ordered", "gmm-mc", "quantile-range",
                          "quantile-mean", "quantile-mean-mass", "iqr", "quartile-lower",
                          "quartile-middle", "quartile-upper"]
    by = {m["name"]: m for m in state["models"]}
    assert by["quantile-mean"]["label"] == "quantile-mean (q=8)" and by["quantile-mean"]["available"]
    assert not by["members"]["available"] and by["members"]["reason"]
    assert state["truth"] and state["model"]["dims"] == [32, 32, 32]
    # The page names no model: it starts on defaults.model (the whole quantile population) and
    # its quartile view is the rows covering proper parts of [0, 1] (model_rows.h).
    assert state["defaults"]["model"] == "quantile-range"
    populations = {m["name"]: m["population"] for m in state["models"] if m["population"]}
    assert populations == {"quantile-range": [0, 1], "quartile-lower": [0, 0.25],
                           "quartile-middle": [0.25, 0.75], "quartile-upper": [0.75, 1]}


def test_a_plain_field_starts_on_the_first_available_model(inputs):
    s = Server(inputs.truth, "--tf", inputs.tf)
    try:
        state = s.json("/api/state")
        available = [m["name"] for m in state["models"] if m["available"]]
        assert available[0] == "mean" and "quantile-range" not in available
        assert state["defaults"]["model"] == "mean"
    finally:
        s.stop()


BAD = [
    ("/api/render?size=100000x100000", "size"),
    ("/api/render?size=4096x16", "2048"),
    ("/api/render?size=-3x4", "size"),
    ("/api/render?azimuth=nan", "azimuth"),
    ("/api/render?zoom=inf", "zoom"),
    ("/api/render?zoom=0", "zoom"),
    ("/api/render?elevation=1e400", "elevation"),
    ("/api/render?model=nonsense", "unknown model"),
    ("/api/render?model=members", "ensemble"),
    ("/api/render?realizations=100000&model=gmm-mc", "realizations"),
    ("/api/render?step=1e-9", "step"),
    ("/api/render?position=../../etc/passwd", "position"),
    ("/api/render?model=%2Fetc%2Fpasswd", "unknown model"),
    ("/api/render?file=/etc/passwd", "unknown parameter"),
    ("/api/render?size=8x8&size=9x9", "twice"),
    ("/api/render?channel=../x", "channel"),
    ("/api/render?view=up", "view"),
    ("/api/render?format=jpeg", "format"),
    ("/api/render?position=1,1,1&view=+x", "view"),
    ("/api/probe?x=5", "x and y"),
    ("/api/probe?size=8x8&x=8&y=1", "x"),
    ("/api/probe?point=99,0,0", "outside"),
    ("/api/probe?model=gmm-mc&point=1,1,1", "gmm-mc"),
    ("/api/histogram?bins=0", "bins"),
    ("/api/histogram2d?bins=5000", "bins"),
    ("/api/histogram2d?bins=64&domain=1,0,0,1", "domain"),
    ("/api/histogram2d?domain=nan,1,0,1", "domain"),
    ("/api/tf2", "--tf2"),
    ("/api/tf2/row?y=1&lo=0&hi=1", "--tf2"),
    ("/api/preset?name=../../tf", "preset"),
    ("/api/nothing", "no such endpoint"),
]


@pytest.mark.parametrize("path,mention", BAD)
def test_bad_requests_get_a_4xx_with_a_message(server, path, mention):
    status, _, body = server.get(path)
    assert 400 <= status < 500, (status, body[:200])
    message = json.loads(body)["error"]
    assert mention.lower() in message.lower() and "\n" not in message
    assert server.alive()


@pytest.mark.parametrize("body", [b'{"RGBPoints": [', b"[]",
                                  b'[{"RGBPoints": [0, 0, 0, 0], "Points": [0, "a", 0.5, 0]}]',
                                  b'[{"RGBPoints": [1, 0, 0, 0, 0, 1, 1, 1], "Points": [0, 2, 0.5, 0]}]',
                                  b"\xff\xfe"])
def test_broken_tf_json_is_refused_and_the_tf_kept(server, body):
    before = server.get("/api/tf")[2]
    status, _, answer = server.get("/api/tf", data=body, method="POST")
    assert status == 400 and json.loads(answer)["error"]
    assert server.get("/api/tf")[2] == before


def test_path_like_requests_never_reach_files(server):
    for path in ["/../../../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/web/app.js",
                 "/index.html/../../CMakeLists.txt", "/CMakeLists.txt"]:
        status, _, body = server.get(path)
        assert status == 404 and b"root:" not in body
    status, headers, body = server.get("/")
    assert status == 200 and headers["Content-Type"].startswith("text/html")
    assert server.get("/app.js")[1]["Content-Type"].startswith("text/javascript")


def test_a_burst_of_200_requests_leaves_no_backlog(server, inputs, tmp_path):
    """200 requests on one channel, sent at once in any order: the newest (seq 200) is answered with
    its own image, older ones are superseded or cancelled, and nothing is left queued."""
    def one(seq):
        q = urllib.parse.urlencode({"model": "quantile-mean", "size": "160x160",
                                    "azimuth": seq * 1.5, "channel": "burst", "seq": seq})
        return seq, server.get("/api/render?" + q)

    with concurrent.futures.ThreadPoolExecutor(16) as pool:
        answers = dict(pool.map(one, reversed(range(1, 201))))
    status, _, body = answers[200]
    assert status == 200
    cli = cli_render(inputs, tmp_path / "c.png", "--tf", inputs.tf, "--model", "quantile-mean",
                     "--size", "160x160", "--azimuth", "300")
    assert np.array_equal(png_pixels(body), cli)
    codes = [a[0] for a in answers.values()]
    assert set(codes) <= {200, 409} and codes.count(409) > 100
    stats = server.json("/api/status")
    assert stats["running"] == 0 and stats["waiting"] == 0
    assert stats["superseded"] + stats["cancelled"] >= codes.count(409)


def test_serve_cli_errors(inputs, tmp_path):
    assert_one_line_error(run_udvr("serve", tmp_path / "missing.vti"), "missing.vti")
    assert_one_line_error(run_udvr("serve", inputs.model, "--second", inputs.model), "--tf2")
    assert_one_line_error(run_udvr("serve", inputs.model, "--port", "70000"), "port")
    assert_one_line_error(run_udvr("serve", inputs.model, "--tf", tmp_path / "none.json"), "none.json")
    s = Server(inputs.model, "--tf", inputs.tf)
    try:
        assert s.url.startswith("http://127.0.0.1:")
        port = s.url.rsplit(":", 1)[1]
        r = run_udvr("serve", inputs.model, "--port", port, timeout=20)
        assert_one_line_error(r, port)
    finally:
        s.stop()


# ---- 2D transfer functions: the joint histogram, widget JSON in and out ------------------------
TANGLE_TF2 = ROOT / "data" / "tf2" / "tangle.json"


@pytest.fixture(scope="module")
def server2(inputs):
    s = Server(inputs.model, "--tf2", TANGLE_TF2)
    yield s
    s.stop()


def test_histogram2d_is_udvr_tf2s(server2, inputs):
    """The joint histogram of (mean value, gradient magnitude) over the TF2's domain: the counts
    `udvr tf2 --volume` reports (total, outside, ranges)."""
    h = server2.json("/api/histogram2d?bins=64x48")
    assert h["bins"] == [64, 48] and len(h["counts"]) == 64 * 48
    assert h["domain"] == json.loads(TANGLE_TF2.read_text())["domain"]
    out = run_ok("tf2", TANGLE_TF2, "--volume", inputs.model, "--bins", "64x48").stdout
    m = re.search(r"histogram: (\d+) grid points of .*, value \[(\S+), (\S+)\], gradient "
                  r"magnitude \[(\S+), (\S+)\]; (\d+) outside", out)
    assert m, out
    assert h["total"] == int(m[1]) == 32 ** 3 and h["outside"] == int(m[6])
    assert h["range"] == pytest.approx([float(m[k]) for k in (2, 3, 4, 5)], rel=1e-5, abs=1e-6)
    assert sum(h["counts"]) == h["total"] - h["outside"]
    full = server2.json("/api/histogram2d?bins=8&domain=-100,100,0,1000")
    assert full["bins"] == [8, 8] and full["outside"] == 0 and sum(full["counts"]) == 32 ** 3


def test_posted_tf2_renders_as_the_cli(server2, inputs, tmp_path):
    """Widget JSON posted (a box moved, a flat triangle added, a colour changed) renders as
    `udvr render --tf2` of the same text, and of the JSON GET /api/tf2 gives back."""
    doc = json.loads(TANGLE_TF2.read_text())
    del doc["resolution"]  # the default, 256x256, as the CLI's
    doc["widgets"][2]["x"] = [3.5, 5.25]
    doc["widgets"][1]["rgba"] = [0.1, 0.8, 0.3, 0.7]
    doc["widgets"].append({"type": "triangle", "apex": [10.0, 0.0], "top": 30.0, "width": 4.0,
                           "falloff": "flat", "rgba": [0.9, 0.9, 0.2, 0.4]})
    text = json.dumps(doc)
    v0 = server2.json("/api/state")["tf2_version"]
    assert server2.json("/api/tf2", data=text.encode(), method="POST")["tf_version"] == v0 + 1
    (tmp_path / "posted.json").write_text(text)
    status, headers, saved = server2.get("/api/tf2")
    assert status == 200 and headers["X-Udvr-Tf-Version"] == str(v0 + 1)
    back = json.loads(saved)
    assert back["widgets"] == doc["widgets"] and back["resolution"] == [256, 256]
    (tmp_path / "saved.json").write_bytes(saved)
    params = {"model": "quantile-mean", "size": "72x64", "azimuth": 40, "elevation": 10}
    page, headers = render(server2, **params)
    assert headers["X-Udvr-Tf-Version"] == str(v0 + 1)
    for f in ("posted.json", "saved.json"):
        cli = cli_render(inputs, tmp_path / "cli.png", "--tf2", tmp_path / f, *flags_of(params))
        assert np.array_equal(page, cli), f
    assert page[..., 3].max() > 0


BAD_TF2 = [
    (b'{"domain": [0, 1, 0, 1], "widgets": [', "JSON"),
    (b'{"widgets": []}', "domain"),
    (b'{"domain": [1, 0, 0, 1], "widgets": []}', "domain"),
    (b'{"domain": [0, 1, 0, 1], "widgets": [{"type": "star", "rgba": [1, 1, 1, 1]}]}', "star"),
    (b'{"domain": [0, 1, 0, 1], "widgets": [{"type": "box", "x": [0, 1], "y": [0, 1], '
     b'"rgba": [1, 1, 1, 2]}]}', "rgba"),
    (b'{"domain": [0, 1, 0, 1], "widgets": [{"type": "ellipse", "center": [0, 0], '
     b'"sigma": [-1, 1], "rgba": [1, 1, 1, 1]}]}', "sigma"),
    (b'{"domain": [0, 1, 0, 1], "resolution": [4096, 4096], "widgets": []}', "1024"),
    (b'{"domain": [0, 1, 0, 1], "widgets": [' + b",".join(
        [b'{"type": "box", "x": [0, 1], "y": [0, 1], "rgba": [1, 1, 1, 0.1]}'] * 300) + b"]}",
     "256"),
    (b"\xff\xfe", "JSON"),
]


@pytest.mark.parametrize("body,mention", BAD_TF2, ids=[f"{k}-{m}" for k, (_, m) in
                                                        enumerate(BAD_TF2)])
def test_broken_tf2_json_is_refused_and_the_tf2_kept(server2, body, mention):
    before = server2.get("/api/tf2")[2]
    status, _, answer = server2.get("/api/tf2", data=body, method="POST")
    assert status == 400, answer[:200]
    message = json.loads(answer)["error"]
    assert mention.lower() in message.lower() and "\n" not in message
    assert server2.get("/api/tf2")[2] == before and server2.alive()


def assert_row_is_the_raster(row, raster, domain, y, lo, hi, n):
    """GET /api/tf2/row's answer: n values from lo to hi (ends exact) and the raster's bilinear,
    clamped colour and opacity there."""
    assert row["y"] == y and len(row["x"]) == len(row["rgba"]) == n
    assert row["x"][0] == lo and row["x"][-1] == hi
    assert np.allclose(row["x"], np.linspace(lo, hi, n), rtol=0, atol=1e-12)
    want = [tf2_at(raster, domain, x, y) for x in row["x"]]
    assert np.allclose(row["rgba"], want, rtol=0, atol=1e-7)  # a float32 raster's precision


def test_tf2_row_is_the_cli_raster(server2, tmp_path):
    """The TF2 along x at one y (the probe plot's curve): the raster `udvr tf2 -o` writes of the
    current widgets, bilinear, clamped beyond the domain on both axes."""
    (tmp_path / "now.json").write_bytes(server2.get("/api/tf2")[2])
    doc = json.loads((tmp_path / "now.json").read_text())
    raster = tf2_raster(tmp_path / "now.json", tmp_path / "now.npy")
    for y, lo, hi, n in [(12.5, -10.0, 40.0, 101), (70.0, -3.25, 0.5, 2), (-1.0, -7.0, 35.0, 256)]:
        status, headers, body = server2.get(f"/api/tf2/row?y={y}&lo={lo}&hi={hi}&n={n}")
        assert status == 200, body[:200]
        assert headers["X-Udvr-Tf-Version"] == str(server2.json("/api/state")["tf2_version"])
        assert_row_is_the_raster(json.loads(body), raster, doc["domain"], y, lo, hi, n)
    assert max(a for *_, a in server2.json("/api/tf2/row?y=12.5&lo=-7&hi=35")["rgba"]) > 0
    assert len(server2.json("/api/tf2/row?y=0&lo=0&hi=1")["x"]) == 256  # the default n


@pytest.mark.parametrize("query,mention", [
    ("lo=0&hi=1", "give y"),
    ("y=1&lo=0", "give y"),
    ("y=nan&lo=0&hi=1", "y"),
    ("y=1e400&lo=0&hi=1", "y"),
    ("y=1&lo=1&hi=1", "above"),
    ("y=1&lo=2&hi=1", "above"),
    ("y=1&lo=0&hi=1&n=1", "n"),
    ("y=1&lo=0&hi=1&n=5000", "n"),
    ("y=1&lo=0&hi=1&n=-3", "n"),
    ("y=1&lo=0&hi=1&x=2", "unknown parameter"),
    ("y=1&y=2&lo=0&hi=1", "twice"),
])
def test_bad_tf2_row_requests(server2, query, mention):
    status, _, body = server2.get("/api/tf2/row?" + query)
    assert status == 400, body[:200]
    message = json.loads(body)["error"]
    assert mention.lower() in message.lower() and "\n" not in message
    assert server2.get("/api/tf2/row", data=b"{}", method="POST")[0] == 405
    assert server2.alive()


def test_tf2_endpoints_need_a_tf2(server):
    status, _, body = server.get("/api/tf2", data=b'{"domain": [0, 1, 0, 1], "widgets": []}',
                                 method="POST")
    assert status == 400 and "--tf2" in json.loads(body)["error"]
    h = server.json("/api/histogram2d?bins=16")  # over the data's ranges
    assert h["outside"] == 0 and sum(h["counts"]) == 32 ** 3


def test_bivariate_histogram_and_tf2(inputs, tmp_path):
    """--second: the histogram is field 1 x field 2, and posted widgets render as the CLI's."""
    start = {"domain": [-7, 35, -7, 35], "widgets": [
        {"type": "band", "points": [[-7, -7], [35, 35]], "half_width": [1.5, 1.5],
         "rgba": [0.9, 0.5, 0.1, 0.5]}]}
    (tmp_path / "start.json").write_text(json.dumps(start))
    s = Server(inputs.model, "--tf2", tmp_path / "start.json", "--second", inputs.truth)
    try:
        h = s.json("/api/histogram2d?bins=32")
        assert h["y"].startswith("field 2") and h["domain"] == [-7, 35, -7, 35]
        # The second is a plain field: the models that need more arrays are not offered.
        models = {m["name"]: m for m in s.json("/api/state")["models"]}
        assert models["gaussian"]["available"] and models["mean"]["available"]
        assert not models["quantile-range"]["available"]
        assert models["quantile-range"]["reason"].startswith("--second ")
        status, _, body = s.get("/api/render?model=quantile-range&size=16x16")
        assert status == 400 and "quantiles" in json.loads(body)["error"]
        assert h["total"] == 32 ** 3
        start["widgets"].append({"type": "ellipse", "center": [0, 0], "sigma": [3, 3],
                                 "rgba": [0.2, 0.3, 0.9, 0.8]})
        s.json("/api/tf2", data=json.dumps(start).encode(), method="POST")
        (tmp_path / "saved.json").write_bytes(s.get("/api/tf2")[2])
        page, _ = render(s, model="gaussian", size="64x64", azimuth=20)
        cli = cli_render(inputs, tmp_path / "cli.png", "--tf2", tmp_path / "saved.json",
                         "--second", inputs.truth, "--model", "gaussian", "--size", "64x64",
                         "--azimuth", "20")
        assert np.array_equal(page, cli) and page[..., 3].max() > 0
    finally:
        s.stop()


def test_a_raster_tf2_renders_but_is_not_editable(inputs, tmp_path):
    run_ok("tf2", TANGLE_TF2, "-o", tmp_path / "raster.vti")
    s = Server(inputs.model, "--tf2", tmp_path / "raster.vti")
    try:
        state = s.json("/api/state")
        assert state["tf2"].endswith("raster.vti") and not state["tf2_editable"]
        status, _, body = s.get("/api/tf2")
        assert status == 400 and "raster" in json.loads(body)["error"]
        assert s.json("/api/histogram2d?bins=16")["domain"] == [-7, 35, 0, 60]
        page, _ = render(s, model="mean", size="48x48")
        cli = cli_render(inputs, tmp_path / "cli.png", "--tf2", tmp_path / "raster.vti",
                         "--model", "mean", "--size", "48x48")
        assert np.array_equal(page, cli)
        # Its row (the probe plot's curve) too, from the same raster.
        raster = tf2_raster(TANGLE_TF2, tmp_path / "raster.npy")
        row = s.json("/api/tf2/row?y=20&lo=-8&hi=36&n=64")
        assert_row_is_the_raster(row, raster, [-7, 35, 0, 60], 20.0, -8.0, 36.0, 64)
    finally:
        s.stop()
