"""The CLI against careless and hostile input (issue 34, items 10-15): outputs that would replace
an input, XML nested until the parser's stack overflows, geometry and model values no model holds,
small inputs that ask for unbounded work, and messages that named the wrong thing. Each case:
one line "udvr: error: ...", a non-zero exit, the inputs untouched and no output left behind (or,
where the input was valid, the right result).
"""
import base64
import json
import os
import pathlib
import struct
import time

import pytest

from conftest import assert_one_line_error, listing, run_ok, run_udvr, write_tf

pytestmark = pytest.mark.usefixtures("udvr_binary")


def ascii_vti(path, dims, arrays, spacing="1 1 1", origin="0 0 0", field_data=""):
    """An uncompressed .vti by hand (no VTK needed): arrays is {name: (components, values)} with
    x fastest, written inline as base64 binary (NaN and Inf survive); Spacing and Origin exactly
    as given (so that bad text reaches the reader)."""
    x, y, z = dims
    extent = f"0 {x - 1} 0 {y - 1} 0 {z - 1}"
    body = []
    for name, (components, values) in arrays.items():
        raw = struct.pack(f"<{len(values)}f", *values)
        text = base64.b64encode(struct.pack("<Q", len(raw)) + raw).decode()
        body.append(f'<DataArray type="Float32" Name="{name}" NumberOfComponents="{components}" '
                    f'format="binary">{text}</DataArray>')
    path = pathlib.Path(path)
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" '
        'byte_order="LittleEndian" header_type="UInt64">\n'
        f'<ImageData WholeExtent="{extent}" Origin="{origin}" Spacing="{spacing}">\n'
        f'{field_data}<Piece Extent="{extent}"><PointData>{"".join(body)}</PointData>'
        '<CellData/></Piece>\n</ImageData>\n</VTKFile>\n')
    return path


def snapshot(*paths):
    return {p: pathlib.Path(p).read_bytes() for p in paths}


def assert_unchanged(before):
    for p, data in before.items():
        assert pathlib.Path(p).read_bytes() == data, f"{p} was changed"


# ---- item 10: an output that resolves to an input is refused before any work -------------------


@pytest.fixture
def field(tmp_path):
    f = tmp_path / "t.vti"
    run_ok("generate", "tangle", "--dims", "12", "-o", f)
    return f


def test_build_onto_its_own_input_is_refused(tmp_path, field):
    before = snapshot(field)
    r = run_udvr("build", field, "--downsample", "2", "-o", field)
    assert_one_line_error(r, "-o", "is also an input", "t.vti")
    assert_unchanged(before)
    assert listing(tmp_path) == ["t.vti"]


def test_output_through_a_symlink_or_hard_link_is_refused(tmp_path, field):
    before = snapshot(field)
    (tmp_path / "sym.vti").symlink_to(field)
    os.link(field, tmp_path / "hard.vti")
    for out in ("sym.vti", "hard.vti", "./sub/../t.vti"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        r = run_udvr("build", "t.vti", "--downsample", "2", "-o", out, cwd=tmp_path)
        assert_one_line_error(r, "is also an input")
    assert_unchanged(before)


def test_glob_member_as_output_is_refused(tmp_path, field):
    ens = tmp_path / "ens"
    ens.mkdir()
    for i in range(3):
        (ens / f"mem_{i + 1}.vti").write_bytes(field.read_bytes())
    before = snapshot(*ens.iterdir())
    r = run_udvr("build", ens / "mem_*.vti", "-o", ens / "mem_1.vti")
    assert_one_line_error(r, "is also an input", "mem_1.vti", "mem_*.vti")
    assert_unchanged(before)
    assert sorted(p.name for p in ens.iterdir()) == ["mem_1.vti", "mem_2.vti", "mem_3.vti"]


def test_every_writing_command_checks(tmp_path, field):
    nc = tmp_path / "f.nc"
    run_ok("generate", "tangle", "--dims", "8", "-o", nc)
    img = tmp_path / "a.png"
    run_ok("render", field, "--size", "16x16", "-o", img)
    tf = write_tf(tmp_path / "tf.json")
    raster = tmp_path / "r.vti"
    widgets = tmp_path / "w.json"
    widgets.write_text(json.dumps({"domain": [0, 1, 0, 1], "widgets": [
        {"type": "box", "rgba": [1, 0, 0, 1], "x": [0.2, 0.4], "y": [0, 1]}]}))
    run_ok("tf2", widgets, "-o", raster)
    before = snapshot(field, nc, img, tf, raster)
    cases = [
        (["perturb", nc, "-o", nc], "-o"),
        (["compare", img, img, "--diff", img], "--diff"),
        (["render", field, "--tf", tf, "--save-tf", tf, "-o", tmp_path / "b.png"], "--save-tf"),
        (["tf2", raster, "-o", raster], "-o"),
        (["info", img, "--histogram", img], "--histogram"),
        (["probe", img, "--point", "1,1,1", "--plot", img], "--plot"),
    ]
    for args, flag in cases:
        assert_one_line_error(run_udvr(*args), flag, "is also an input")
    assert_unchanged(before)


def test_pieces_of_a_pvti_count_as_inputs(tmp_path, field):
    run_ok("build", field, "--downsample", "2", "--pieces", "2", "-o", tmp_path / "m.pvti")
    piece = tmp_path / "m" / "m_0.vti"
    before = snapshot(piece, tmp_path / "m.pvti")
    r = run_udvr("build", tmp_path / "m.pvti", "--downsample", "2", "-o", piece)
    assert_one_line_error(r, "piece")
    r = run_udvr("build", piece, "--downsample", "2", "-o", tmp_path / "m.pvti")
    assert_one_line_error(r, "piece")
    assert_unchanged(before)


def test_experiment_output_folder_is_not_its_data_folder(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    r = run_udvr("experiment", "tangle", "--quick", "-o", data, "--data-dir", data)
    assert_one_line_error(r, "output folder", "is also an input")
    assert listing(data) == []


# ---- item 11: XML nested deeper than the parser's stack ---------------------------------------


def deep_xml(path, depth=150_000):
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" '
                    'byte_order="LittleEndian">' + "<a>" * depth + "</a>" * depth + "</VTKFile>\n")
    return path


@pytest.mark.parametrize("ext", [".vti", ".pvti"])
def test_deeply_nested_xml_is_one_line_not_a_crash(tmp_path, ext):
    deep = deep_xml(tmp_path / f"deep{ext}")
    assert deep.stat().st_size > 1_000_000
    cases = [["info", deep], ["render", deep, "-o", tmp_path / "x.png"]]
    if ext == ".vti":  # build reads fields, not .pvti
        cases.append(["build", deep, "--downsample", "2", "-o", tmp_path / "m.vti"])
    for args in cases:
        r = run_udvr(*args)
        assert r.returncode not in (-11, 139), "crashed (SIGSEGV)"
        assert_one_line_error(r, "nested deeper than 256")
    assert listing(tmp_path) == [deep.name]


def test_nesting_a_little_deeper_than_vtk_writes_still_reads(tmp_path):
    # Comments, CDATA and quoted '>' do not count as elements.
    f = ascii_vti(tmp_path / "ok.vti", (2, 2, 2), {"v": (1, range(8))},
                  field_data='<!-- <a><b><c> --><![CDATA[<x><y>]]>')
    text = f.read_text().replace('Spacing="1 1 1"', "Spacing=\"1 1 1\" note='a>b/>'")
    f.write_text(text)
    assert "8 points" in run_ok("info", f).stdout.replace("(8)", "8 points")


# ---- item 13: geometry VTK would silently replace -----------------------------------------------


@pytest.mark.parametrize("attr,text", [
    ("spacing", "nan inf -1"), ("spacing", "abc"), ("spacing", "1 1"), ("spacing", "1 0 1"),
    ("origin", "1e308 -inf nan"), ("origin", "0 0 x"),
])
def test_bad_spacing_or_origin_is_an_error(tmp_path, attr, text):
    f = ascii_vti(tmp_path / "f.vti", (2, 2, 2), {"v": (1, range(8))}, **{attr: text})
    for args in (["info", f], ["render", f, "-o", tmp_path / "x.png"]):
        assert_one_line_error(run_udvr(*args), attr, text)
    assert not (tmp_path / "x.png").exists()


def test_origin_so_large_the_grid_overflows_is_an_error(tmp_path):
    f = ascii_vti(tmp_path / "f.vti", (2, 2, 2), {"v": (1, range(8))}, origin="1.7e308 0 0",
                  spacing="1e308 1 1")
    assert_one_line_error(run_udvr("info", f), "corner")


def test_nrrd_whose_far_corner_overflows_is_an_error(tmp_path):
    (tmp_path / "n.raw").write_bytes(struct.pack("<27f", *range(27)))
    f = tmp_path / "n.nhdr"
    f.write_text("NRRD0004\ntype: float\ndimension: 3\nsizes: 3 3 3\n"
                 "spacings: 1e308 1 1\nendian: little\nencoding: raw\ndata file: n.raw\n")
    assert_one_line_error(run_udvr("info", f), "far corner")


def model_arrays(**change):
    """A valid 2x2x2 model (q = 2, K = 1) as ascii_vti arrays, with `change` applied."""
    n = 8
    a = {"mean": (1, [1.0] * n), "stddev": (1, [0.5] * n), "min": (1, [0.0] * n),
         "max": (1, [2.0] * n), "quantiles": (3, [0.0, 1.0, 2.0] * n),
         "iqr": (2, [0.5, 1.5] * n), "gmm": (3, [1.0, 1.0, 0.5] * n)}
    for name, (voxel, component, value) in change.items():
        components, values = a[name]
        values = list(values)
        values[voxel * components + component] = value
        a[name] = (components, values)
    return a


QUANTILE_FIELD_DATA = ('<FieldData><DataArray type="Int32" Name="quantile_count" '
                       'NumberOfTuples="1" format="ascii">2</DataArray><DataArray type="Int32" '
                       'Name="gmm_components" NumberOfTuples="1" format="ascii">1</DataArray>'
                       '</FieldData>')


@pytest.mark.parametrize("change,mentions", [
    (dict(stddev=(7, 0, -0.5)), ["array 'stddev'", "negative", "-0.5", "(1, 1, 1)"]),
    (dict(stddev=(1, 0, 3e38)), ["array 'stddev'", "(1, 0, 0)"]),
    (dict(quantiles=(2, 1, -1.0)), ["array 'quantiles'", "decreases", "(0, 1, 0)"]),
    (dict(quantiles=(3, 1, float("nan"))), ["array 'quantiles'", "nan", "(1,1,0)"]),
    (dict(min=(4, 0, 5.0)), ["array 'min'", "(0, 0, 1)"]),
    (dict(iqr=(0, 0, 9.0)), ["array 'iqr'", "decreases"]),
    (dict(gmm=(5, 0, 1.5)), ["array 'gmm'", "weight"]),
    (dict(gmm=(5, 2, -1.0)), ["array 'gmm'", "sigma", "negative"]),
])
def test_impossible_model_arrays_name_array_and_voxel(tmp_path, change, mentions):
    m = ascii_vti(tmp_path / "m.vti", (2, 2, 2), model_arrays(**change),
                  field_data=QUANTILE_FIELD_DATA)
    for model in ("gaussian", "quantile-range"):
        r = run_udvr("render", m, "--model", model, "-o", tmp_path / "x.png")
        line = assert_one_line_error(r, "m.vti", *mentions)
        assert "plain field" not in line
    assert not (tmp_path / "x.png").exists()


def test_a_valid_hand_written_model_renders(tmp_path):
    m = ascii_vti(tmp_path / "m.vti", (2, 2, 2), model_arrays(), field_data=QUANTILE_FIELD_DATA)
    run_ok("render", m, "--model", "quantile-range", "--size", "16x16", "-o", tmp_path / "x.png")


# ---- item 12: internal checks from valid input --------------------------------------------------


def test_constant_field_of_1e17_renders_with_the_default_tf(tmp_path):
    f = ascii_vti(tmp_path / "c.vti", (4, 4, 4), {"v": (1, [1e17] * 64)})
    r = run_ok("render", f, "--size", "16x16", "-o", tmp_path / "c.png")
    assert "internal" not in r.stderr
    assert (tmp_path / "c.png").stat().st_size > 0


# ---- item 14: small inputs that ask for unbounded work ------------------------------------------


def test_widget_raster_over_the_cap_needs_force(tmp_path):
    widgets = [{"type": "ellipse", "rgba": [1, 0, 0, 0.5], "center": [i / 256, 0.5],
                "sigma": [0.1, 0.2], "angle": 30} for i in range(256)]
    f = tmp_path / "big.json"
    f.write_text(json.dumps({"domain": [0, 1, 0, 1], "resolution": [8192, 8192],
                             "widgets": widgets}))
    assert f.stat().st_size < 30_000
    t = time.monotonic()
    for args in (["tf2", f, "-o", tmp_path / "r.npy"],
                 ["render", tmp_path / "none.vti", "--tf2", f, "-o", tmp_path / "x.png"]):
        assert_one_line_error(run_udvr(*args), "widget evaluations", "--force")
    assert time.monotonic() - t < 10
    assert listing(tmp_path) == ["big.json"]
    # The default resolution is well within the cap.
    run_ok("tf2", f, "--tf2-resolution", "256x256")


def test_threads_flag_is_clamped(tmp_path, field):
    r = run_ok("--threads", "4096", "build", field, "--downsample", "2", "--gmm", "0",
               "-o", tmp_path / "m.vti")
    threads = int(r.stderr.split(" threads")[0].split()[-1])
    assert threads <= 4 * os.cpu_count()


# ---- item 15: messages that named the wrong thing -------------------------------------------------


def test_huge_ellipse_angle_is_reduced_not_a_colour_error(tmp_path):
    f = tmp_path / "e.json"
    f.write_text(json.dumps({"domain": [0, 1, 0, 1], "widgets": [
        {"type": "ellipse", "rgba": [1, 0, 0, 1], "center": [0.5, 0.5], "sigma": [0.1, 0.2],
         "angle": 1e308}]}))
    run_ok("tf2", f)


def test_histogram2d_bins_error_names_its_own_limit(tmp_path):
    from serve_util import Server
    f = tmp_path / "t.vti"
    run_ok("generate", "tangle", "--dims", "8", "-o", f)
    s = Server(f)
    try:
        for bins in ("0", "5000", "0x8"):
            status, _, body = s.get(f"/api/histogram2d?bins={bins}")
            assert status == 400
            assert b"1024" in body and b"16384" not in body, body
    finally:
        s.stop()
