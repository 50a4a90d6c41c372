"""Partitioned models (issue 15 point 3): `udvr build -o m.pvti` writes VTK's parallel ImageData
(a .pvti naming z-pieces m/m_<i>.vti that share their boundary planes); render, probe and info
read it as the one model it was built from (docs/formats.md, "Partitioned models")."""
import json
import pathlib
import xml.etree.ElementTree as ET

import pytest

from conftest import assert_one_line_error, run_ok, run_udvr, write_tf

pytestmark = pytest.mark.usefixtures("udvr_binary")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    d = tmp_path_factory.mktemp("pvti")
    run_ok("generate", "tangle", "--dims", "24", "-o", d / "f.vti")
    run_ok("perturb", d / "f.vti", "--members", "12", "-o", d / "e.nc")
    run_ok("build", d / "e.nc", "--gmm", "3", "-o", d / "m.vti")
    r = run_ok("build", d / "e.nc", "--gmm", "3", "--pieces", "5", "-o", d / "m.pvti")
    assert "m.pvti (5 pieces)" in r.stderr
    write_tf(d / "tf.json", [-10, 0, 0, 1, 30, 1, 1, 0], [-10, 0, 0.5, 0, 30, 0.8, 0.5, 0])
    return d


def test_the_header_names_pieces_that_share_planes_and_cover_the_grid(built):
    root = ET.parse(built / "m.pvti").getroot()
    assert root.get("type") == "PImageData"
    image = root.find("PImageData")
    assert image.get("WholeExtent") == "0 23 0 23 0 23"
    pieces = image.findall("Piece")
    assert [p.get("Source") for p in pieces] == [f"m/m_{i}.vti" for i in range(5)]
    z = [tuple(int(v) for v in p.get("Extent").split()[4:]) for p in pieces]
    assert z[0][0] == 0 and z[-1][1] == 23
    assert all(a[1] == b[0] for a, b in zip(z, z[1:]))  # one shared plane, no gap
    names = [a.get("Name") for a in image.find("PPointData").findall("PDataArray")]
    assert names == ["mean", "stddev", "min", "max", "quantiles", "iqr", "gmm"]
    assert sorted(p.name for p in (built / "m").iterdir()) == [f"m_{i}.vti" for i in range(5)]


@pytest.mark.parametrize("model", ["mean", "gaussian", "uniform", "quantile-range",
                                   "quantile-mean", "gmm-ordered", "iqr"])
def test_renders_the_same_image_as_the_whole_model(built, tmp_path, model):
    images = []
    for name in ("m.vti", "m.pvti"):
        out = tmp_path / (name + ".pfm")
        run_ok("render", built / name, "--model", model, "--tf", built / "tf.json", "--size", "48",
               "--float", out, "-o", tmp_path / (name + ".png"))
        images.append(out.read_bytes())
    assert images[0] == images[1]


def test_probe_and_info_read_it_as_one_model(built):
    # The point lies in the plane two pieces share and in the cells on both sides of it.
    root = ET.parse(built / "m.pvti").getroot()
    shared = int(root.find("PImageData").findall("Piece")[2].get("Extent").split()[4])
    for point in (f"3.5,7.25,{shared}", f"3.5,7.25,{shared - 0.5}", f"11,2,{shared + 0.5}"):
        out = [json.loads(run_ok("probe", built / name, "--point", point, "--model",
                                 "quantile-mean", "--tf", built / "tf.json", "--json").stdout)
               for name in ("m.vti", "m.pvti")]
        assert out[0] == out[1]
    info = run_ok("info", built / "m.pvti").stdout
    assert "m.pvti: model" in info and "24x24x24 points" in info and "GMM K = 3" in info


def test_bad_options_and_damaged_pieces_are_one_line_errors(built, tmp_path):
    assert_one_line_error(run_udvr("build", built / "e.nc", "--pieces", "3", "-o", tmp_path / "x.vti"),
                          "--pieces", ".pvti")
    assert_one_line_error(run_udvr("build", built / "e.nc", "--pieces", "-2", "-o",
                                   tmp_path / "x.pvti"), "--pieces -2", "out of range")
    # A copy whose piece 3 is missing, and one whose piece 1 is truncated.
    for damage in ("missing", "truncated"):
        copy = tmp_path / damage
        (copy / "m").mkdir(parents=True)
        (copy / "m.pvti").write_bytes((built / "m.pvti").read_bytes())
        for piece in (built / "m").iterdir():
            (copy / "m" / piece.name).write_bytes(piece.read_bytes())
        if damage == "missing":
            (copy / "m" / "m_3.vti").unlink()
        else:
            data = (copy / "m" / "m_1.vti").read_bytes()
            (copy / "m" / "m_1.vti").write_bytes(data[: len(data) // 2])
        for cmd in (["render", copy / "m.pvti", "-o", copy / "i.png"],
                    ["probe", copy / "m.pvti", "--point", "1,1,1"]):
            assert_one_line_error(run_udvr(*cmd), "m.pvti", "piece " + ("3" if damage == "missing"
                                                                       else "1"))
        assert not (copy / "i.png").exists()


def test_fewer_pieces_replace_more(built, tmp_path):
    out = tmp_path / "p.pvti"
    run_ok("build", built / "e.nc", "--gmm", "0", "--pieces", "6", "-o", out)
    run_ok("build", built / "e.nc", "--gmm", "0", "--pieces", "2", "-o", out)
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == ["p_0.vti", "p_1.vti"]
    a = run_ok("probe", out, "--point", "5,5,20", "--model", "quantile-range", "--json").stdout
    run_ok("build", built / "e.nc", "--gmm", "0", "-o", tmp_path / "w.vti")
    b = run_ok("probe", tmp_path / "w.vti", "--point", "5,5,20", "--model", "quantile-range",
               "--json").stdout
    assert json.loads(a) == json.loads(b)
