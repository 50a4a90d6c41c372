"""`import udvr` in Debian's /usr/bin/python3 after scripts/setup.sh, with no environment
variable (issue 14, point 1): a fresh interpreter, started outside the repository with PYTHONPATH
unset, finds the package, and its version is the CLI's."""
import os
import subprocess

from conftest import run_ok


def fresh_python(code, cwd):
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    return subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True,
                          cwd=cwd, env=env, timeout=60, stdin=subprocess.DEVNULL)


def test_import_without_pythonpath_and_version_matches_cli(udvr_binary, tmp_path):
    r = fresh_python("import udvr, numpy; print(udvr.__version__); print(udvr.__file__)",
                     tmp_path)
    assert r.returncode == 0, ("import udvr failed in a fresh /usr/bin/python3 without "
                               f"PYTHONPATH (run scripts/setup.sh):\n{r.stderr}")
    version, path = r.stdout.split()
    cli = run_ok("--version").stdout.split()
    assert cli[0] == "udvr" and version == cli[1], (version, cli)
    assert path.endswith(os.path.join("udvr", "__init__.py"))


def test_compiled_core_is_inside_the_package():
    import udvr
    assert udvr._udvr.__name__ == "udvr._udvr"
    assert udvr.__version__ == udvr._udvr.__version__
    assert udvr.__build__.startswith("target ")
