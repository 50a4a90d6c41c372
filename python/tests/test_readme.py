"""The README's command blocks, run as written (issue 11): every ```sh block of README.md, in
order, in one bash session started in a scratch folder that stands for the repository root
(`build` and `data` link to the real ones). Every command must succeed and write what it says.
"""
import os
import pathlib
import re
import subprocess

import pytest

from conftest import ROOT, UDVR_BINARY

pytestmark = pytest.mark.usefixtures("udvr_binary")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def readme_blocks():
    text = (ROOT / "README.md").read_text()
    return re.findall(r"```sh\n(.*?)```", text, flags=re.S)


def test_readme_has_the_first_session_blocks():
    blocks = readme_blocks()
    assert len(blocks) >= 2, "README.md lost its ```sh blocks"
    first = blocks[0]
    for command in ("udvr info", "udvr render tangle.vti -o", "udvr build", "udvr probe",
                    "udvr compare", "udvr experiment"):
        assert command in first, command
    # The first render shows a volume without a hand-written TF.
    line = first.split("udvr render tangle.vti -o", 1)[1].splitlines()[0].split("#")[0]
    assert not re.search(r"(?<![\w-])--tf2?(?![\w-])", line), line


def test_readme_blocks_run_verbatim(tmp_path):
    root = tmp_path / "repo"
    root.mkdir()
    (root / "build").symlink_to(UDVR_BINARY.resolve().parent, target_is_directory=True)
    (root / "data").symlink_to(ROOT / "data", target_is_directory=True)
    script = "set -euo pipefail\n" + "\n".join(readme_blocks())
    env = dict(os.environ, UDVR_NO_PROGRESS="1")
    r = subprocess.run(["bash", "-c", script], cwd=root, capture_output=True, text=True,
                       timeout=600, env=env, stdin=subprocess.DEVNULL)
    assert r.returncode == 0, f"README blocks failed (exit {r.returncode}):\n{r.stderr[-3000:]}"
    out = root / "try"
    for png in ("histogram.png", "first.png", "probe.png", "model.png", "truth.png",
                "diff.png", "side.png", "tf2-design.png", "tf2.png"):
        assert (out / png).read_bytes()[:8] == PNG_MAGIC, png
    for f in ("tangle.vti", "ensemble.nc", "model.vti", "tf.json", "ens.nc"):
        assert (out / f).stat().st_size > 0, f
    assert (out / "results").is_dir()
    # The default TF was announced and saved; compare printed an RMSE.
    assert "no --tf: the preset 'cool-to-warm'" in r.stderr
    assert re.search(r"RMSE[^\n]*\d", r.stdout + r.stderr), r.stdout[-2000:]
