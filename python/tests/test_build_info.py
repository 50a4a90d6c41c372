"""`udvr.__build__` (the module) and `udvr --version` (the CLI) describe the same build."""
import re

import pytest

from conftest import run_ok

udvr = pytest.importorskip("udvr")

BUILD_RE = re.compile(
    r"target (native|x86-64-v4|x86-64-v3|generic): (AVX-512|AVX2\+FMA|AVX2|AVX|SSE2|NEON|scalar), "
    r"batches of (16 floats \(512 bits\)|8 floats \(256 bits\)|4 floats \(128 bits\)"
    r"|4 floats \(scalar operations\))")


def test_build_string_has_the_documented_form():
    assert BUILD_RE.fullmatch(udvr.__build__), udvr.__build__


def test_cli_version_names_the_same_build(udvr_binary):
    out = run_ok("--version").stdout.strip()
    assert re.fullmatch(r"udvr \d+\.\d+\.\d+ \((.*)\)", out), out
    assert out.endswith(f"({udvr.__build__})"), (out, udvr.__build__)
