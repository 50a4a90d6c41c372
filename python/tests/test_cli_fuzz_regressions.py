"""The inputs of past fuzz findings (fuzz/regressions/, docs/testing.md) through the `udvr`
binary: each gives one line "udvr: error: …" on stderr, a non-zero exit and no output file — no
crash, no log of VTK's, no hang.

Issue 15's files first: a DataArray `type` of Float-7, Int999999999 or Float1e308 crashed
(SIGSEGV) `udvr build x.vti` and `udvr render model.vti`, in ParaView's files and udvr's own.
The fuzz encodings that are not plain files (raw layouts, NRRD with a detached part, member
lists) are replayed by ctest (fuzz_replay.*) instead.
"""
import pathlib
import shutil

import pytest

from conftest import ROOT, assert_one_line_error, listing, run_udvr, write_tf

pytestmark = pytest.mark.usefixtures("udvr_binary")

REGRESSIONS = ROOT / "fuzz" / "regressions"


def _files(target, pattern="*"):
    return sorted((REGRESSIONS / target).glob(pattern))


def _id(p):
    return f"{p.parent.name}/{p.name}"


@pytest.mark.parametrize("src", _files("vti", "issue15-*") + _files("model", "issue15-*"), ids=_id)
def test_issue15_unknown_array_types(src, tmp_path):
    f = tmp_path / "in.vti"
    shutil.copy(src, f)
    bad_type = src.stem.split("-type-")[1]
    tf = write_tf(tmp_path / "tf.json")
    out = tmp_path / "out"
    out.mkdir()
    for args in (
        ["info", f],
        ["build", f, "--downsample", "2", "-o", out / "m.vti"],
        ["render", f, "--model", "mean", "--tf", tf, "--size", "8x8", "-o", out / "i.png"],
        ["probe", f, "--point", "0,0,0", "--model", "mean", "--tf", tf, "--json"],
    ):
        r = run_udvr(*args)
        assert r.returncode == 2, (args, r.returncode, r.stderr)
        assert_one_line_error(r, "in.vti", f"type '{bad_type}'")
        assert r.stdout == ""
    assert listing(out) == []


# Each fuzz target whose input is one file, and the commands that read such a file.
_COMMANDS = {
    "vti": (".vti", [["info", "{f}"], ["build", "{f}", "--downsample", "2", "-o", "{out}/m.vti"]]),
    "model": (".vti", [["render", "{f}", "--model", "mean", "--tf", "{tf}", "--size", "8x8",
                        "-o", "{out}/i.png"]]),
    "tf2_vti": (".vti", [["render", "{model}", "--model", "mean", "--tf2", "{f}", "--size",
                          "8x8", "-o", "{out}/i.png"]]),
    "tf_json": (".json", [["render", "{model}", "--model", "mean", "--tf", "{f}", "--size", "8x8",
                           "-o", "{out}/i.png"]]),
    "netcdf": (".nc", [["build", "{f}", "-o", "{out}/m.vti"]]),
}


@pytest.mark.parametrize(
    "target,src",
    [(t, p) for t in _COMMANDS for p in _files(t) if not p.name.startswith("issue15-")],
    ids=lambda v: v if isinstance(v, str) else v.name,
)
def test_regression_inputs_give_one_line_errors(target, src, pipeline, tmp_path):
    ext, commands = _COMMANDS[target]
    f = tmp_path / f"in{ext}"
    shutil.copy(src, f)
    out = tmp_path / "out"
    out.mkdir()
    names = {"f": f, "out": out, "tf": pipeline.tf, "model": pipeline.model}
    for command in commands:
        args = [a.format(**names) for a in command]
        r = run_udvr(*args, timeout=120)
        assert r.returncode == 2, (args, r.returncode, r.stderr)
        assert_one_line_error(r, f.name)
    assert listing(out) == []
