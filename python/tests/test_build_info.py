"""`udvr.__build__` (the module) and `udvr --version` (the CLI) describe the same build."""
import re

import pytest

from conftest import run_ok

udvr = pytest.importorskip("udvr")

BUILD_RE = re.compile(
    r"target (native|x86-64-v4|x86-64-v3|generic): (AVX-512|AVX2\+FMA|AVX2|AVX|SSE2|NEON|scalar), "
    r"16-float lanes in (1 register of 512 bits|2 registers of 256 bits|4 registers of 128 bits"
    r"|scalar operations)")


def test_build_string_has_the_documented_form():
    assert BUILD_RE.fullmatch(udvr.__build__), udvr.__build__


def test_cli_version_names_the_same_build(udvr_binary):
    out = run_ok("--version").stdout.strip()
    assert re.fullmatch(r"udvr \d+\.\d+\.\d+ \((.*)\)", out), out
    assert out.endswith(f"({udvr.__build__})"), (out, udvr.__build__)
