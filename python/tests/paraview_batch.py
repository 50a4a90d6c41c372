"""Runs examples/paraview/render.py once per argument list in one pvbatch process (ParaView's
start-up is seconds; test_paraview.py renders every model): pvbatch paraview_batch.py JOBS.json,
JOBS.json a list of argument lists. Each job's failure ends the run with render.py's message."""
import json
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "examples" / "paraview"))
import render  # noqa: E402

for args in json.loads(pathlib.Path(sys.argv[1]).read_text()):
    render.main(args)
