"""Run render.py's jobs inside ParaView's GUI, e.g. the GUI as the client of an MPI pvserver.

    UDVR_SRC=$PWD UDVR_JOBS=jobs.json build/paraview/udvr-paraview --server-url=cs://HOST:PORT \
        --script=examples/paraview/gui_render.py

jobs.json is a list of render.py argument lists (MODEL ... -o OUT.png; paths as the server sees
them, absolute paths for -o). The GUI passes no arguments to a --script, hence the file. The GUI
keeps running afterwards, so the script writes UDVR_JOBS_DONE (default: jobs.json + ".done"):
"ok", or the traceback. docs/paraview.md ("Client–server") shows a whole run under Xvfb.
"""
import json
import os
import sys
import traceback

jobs_file = os.environ.get("UDVR_JOBS", "jobs.json")
done_file = os.environ.get("UDVR_JOBS_DONE", jobs_file + ".done")
# render.py's directory: the GUI runs a --script from a string (__file__ is not its path), so
# $UDVR_SRC (the udvr checkout) or the working directory's examples/paraview.
here = os.path.join(os.environ.get("UDVR_SRC", "."), "examples", "paraview")
status = "ok\n"
try:
    sys.path.insert(0, here)
    import paraview.simple as pvs
    import render

    # A view that Python creates in the GUI is drawn only once it sits in a layout: outside one,
    # SaveScreenshot saved an uninitialised buffer (RMSE 0.84 against `udvr render`).
    create_view = pvs.CreateView

    def create_view_in_layout(*args, **kwargs):
        view = create_view(*args, **kwargs)
        pvs.AssignViewToLayout(view=view, layout=pvs.CreateLayout("udvr"))
        return view

    pvs.CreateView = create_view_in_layout
    with open(jobs_file) as f:
        for job in json.load(f):
            render.main([str(v) for v in job])
except SystemExit as e:  # render.py's fail() printed the reason
    status = "render.py failed (exit %s)\n" % e.code
except Exception:
    status = traceback.format_exc()
with open(done_file, "w") as f:
    f.write(status)
