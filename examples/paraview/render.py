"""Render a udvr model in ParaView with the "Uncertain Volume" representation (issue 32).

    build/paraview/udvr-pvbatch examples/paraview/render.py MODEL [--model NAME] [--tf TF.json]
        [--tf2 TF2.vti|TF2.json] [--size WxH] [--azimuth DEG] [--elevation DEG] [--zoom Z] -o OUT.png
    mpirun -np 2 build/paraview/udvr-pvbatch examples/paraview/render.py MODEL.pvti ...
    PYTHONPATH=build/paraview-python/usr/lib/python3/dist-packages PV_PLUGIN_PATH=build/paraview/lib/udvr \
        python3 examples/paraview/render.py --server cs://HOST:PORT MODEL ...  (a pvserver's client)

The arguments are `udvr render`'s and so is the camera (SPEC §5: focal point at the centre of the
model's full-resolution bounds, on +z looking -z with up +y at the distance where the bounding
sphere fits the 30° view angle, divided by the zoom, then VTK's Azimuth and Elevation), so the
image compares with `udvr render MODEL ... -o cli.png` (docs/paraview.md). The TF JSON's colour
points and opacity points become ParaView's lookup table and scalar opacity function for the
`mean` array, in RGB. Run it under `xvfb-run -a -s '-screen 0 1280x1024x24 -noreset'` where
there is no display (Debian's ParaView is GLX only; without -noreset Xvfb resets between
pvbatch's connections and pvbatch may abort), inside `timeout` (pvbatch without a display can
spin). Errors: one line, exit status 1.
"""
import argparse
import json
import math
import os
import re
import sys
import time


def fail(message):
    print("render.py: " + message, file=sys.stderr)
    sys.exit(1)


def parse_args(argv):
    p = argparse.ArgumentParser(prog="render.py", description=__doc__.splitlines()[0])
    p.add_argument("model", metavar="MODEL", help="model .vti or .pvti from `udvr build`")
    p.add_argument("--model", dest="kind", default="mean", help="noise model (udvr render --model)")
    p.add_argument("--tf", help="1D transfer function, ParaView JSON (udvr render --tf)")
    p.add_argument("--tf2", help="2D transfer function: raster .vti or widget .json (udvr render --tf2)")
    p.add_argument("--size", default="512x512", help="WxH (default 512x512)")
    p.add_argument("--azimuth", type=float, default=30.0)
    p.add_argument("--elevation", type=float, default=20.0)
    p.add_argument("--zoom", type=float, default=1.0)
    p.add_argument("--step", type=float, default=0.0)
    p.add_argument("--unit-distance", type=float, default=0.0)
    p.add_argument("--early-exit", type=float, default=0.99)
    p.add_argument("--realizations", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--uniform-width", default="variance", choices=["variance", "std", "minmax"])
    p.add_argument("--background", default="1,1,1", help="r,g,b in [0,1] (default white)")
    p.add_argument("--frames", type=int, default=0,
                   help="also render this many more frames; print the mean frame time and the "
                        "peak RSS of each rank")
    p.add_argument("--pvti-reader", default="udvr", choices=["udvr", "paraview"],
                   help="a .pvti's reader: udvr's (each rank keeps its piece once; default) or "
                        "ParaView's XML reader (keeps each piece twice)")
    p.add_argument("--plugin", default=os.environ.get("UDVR_PARAVIEW_PLUGIN", ""),
                   help="udvr.so (default: $UDVR_PARAVIEW_PLUGIN, which udvr-pvbatch sets)")
    p.add_argument("--server", default="",
                   help="cs://HOST:PORT: render on a running pvserver (started with the plugin, e.g. "
                        "by PV_PLUGIN_PATH), as its client (python3 or pvpython, not pvbatch); "
                        "MODEL and --tf2 are paths on the server, --tf on the client")
    p.add_argument("-o", "--output", required=True, help="PNG to write")
    a = p.parse_args(argv)
    try:
        w, h = (int(v) for v in a.size.lower().split("x"))
        if not (1 <= w <= 16384 and 1 <= h <= 16384):
            raise ValueError
        a.width, a.height = w, h
    except ValueError:
        fail("--size must be WxH with sides in [1, 16384], got '%s'" % a.size)
    if not (a.zoom > 0 and math.isfinite(a.zoom)):
        fail("--zoom must be > 0, got %g" % a.zoom)
    try:
        a.bg = [float(v) for v in a.background.split(",")]
        if len(a.bg) != 3 or not all(0.0 <= v <= 1.0 for v in a.bg):
            raise ValueError
    except ValueError:
        fail("--background must be r,g,b in [0, 1], got '%s'" % a.background)
    if a.server and not re.fullmatch(r"cs://[^:/]+:[0-9]+", a.server):
        fail("--server must be cs://HOST:PORT, got '%s'" % a.server)
    if not a.server and not os.path.isfile(a.model):
        fail("cannot read %s: no such file" % a.model)
    if not a.server and a.tf2 and not os.path.isfile(a.tf2):
        fail("cannot read %s: no such file" % a.tf2)
    return a


def read_tf(path):
    """(RGBPoints, Points) of a ParaView TF JSON (the first object of a list, or an object)."""
    try:
        with open(path) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        fail("cannot read the transfer function %s: %s" % (path, e))
    if isinstance(doc, list):
        doc = doc[0] if doc else {}
    rgb, points = doc.get("RGBPoints"), doc.get("Points")
    if not rgb or len(rgb) % 4 or not points or len(points) % 4:
        fail("%s: expected RGBPoints [x,r,g,b,...] and Points [x,a,0.5,0,...]" % path)
    return [float(v) for v in rgb], [float(v) for v in points]


def separate_steps(values, stride):
    """ParaView's functions hold one point per x; udvr's TFs make a step of two points at one x
    (the later holds from x on). Move the later point right by a hair (1e-9 of the span) so the
    step becomes a ramp ParaView keeps; a sample then differs only within that hair."""
    xs = values[0::stride]
    span = (max(xs) - min(xs)) or 1.0
    out = list(values)
    for i in range(stride, len(out), stride):
        if out[i] <= out[i - stride]:
            out[i] = out[i - stride] + 1e-9 * span
    return out


def main(argv):
    """Render as the module docstring says; returns (view, display) for scripts that go on."""
    a = parse_args(argv)
    from paraview import servermanager
    import paraview.simple
    from paraview.simple import (ColorBy, CreateView, GetColorTransferFunction,
                                 GetOpacityTransferFunction, LoadPlugin, OpenDataFile,
                                 Delete, Render, SaveScreenshot, Show)
    if a.server:
        host, port = a.server[len("cs://"):].rsplit(":", 1)
        try:
            connection = paraview.simple.Connect(host, int(port))
        except RuntimeError as e:
            connection = None
            print("render.py: %s" % e, file=sys.stderr)
        if connection is None:
            fail("cannot connect to the pvserver at %s" % a.server)
    definitions = servermanager.ProxyManager().SMProxyManager.GetProxyDefinitionManager()
    # A pvserver that loaded the plugin hands its proxy definitions to the client, but the client
    # creates the representation's client-side object too and aborts ("Failed to create
    # 'vtkUdvrVolumeRepresentation'") unless the plugin is loaded in the client process as well.
    local = servermanager.vtkSMProxyManager.GetProxyManager().GetPluginManager().GetLocalInformation()
    loaded_here = any(local.GetPluginName(i) == "udvr" and local.GetPluginLoaded(i)
                      for i in range(local.GetNumberOfPlugins()))
    if a.server and not definitions.HasDefinition("representations",
                                                  "UncertainVolumeRepresentation"):
        fail("the pvserver at %s has not loaded the udvr plugin: start it with "
             "PV_PLUGIN_PATH=build/paraview/lib/udvr" % a.server)
    if not loaded_here:
        # Not loaded at start-up from PV_PLUGIN_PATH (which udvr-pvbatch sets).
        if not a.plugin or not os.path.isfile(a.plugin):
            fail("the udvr plugin was not found: run build/paraview/udvr-pvbatch, or pass --plugin")
        LoadPlugin(a.plugin, remote=False, ns=globals())

    def open_model():
        # A .pvti through the plugin's reader (one copy of each rank's piece), else ParaView's.
        if a.model.lower().endswith(".pvti"):
            if a.pvti_reader == "udvr":
                return paraview.simple.udvrPVTIReader(FileName=a.model)
            return paraview.simple.XMLPartitionedImageDataReader(FileName=[a.model])
        return OpenDataFile(a.model)

    reader = open_model()
    if reader is None:
        fail("ParaView cannot open %s" % a.model)
    reader.UpdatePipeline()
    info = reader.GetDataInformation()
    if info.GetNumberOfPoints() == 0:
        fail("%s holds no image data ParaView can read" % a.model)
    arrays = [reader.PointData.GetArray(i).GetName()
              for i in range(reader.PointData.GetNumberOfArrays())]
    if "mean" not in arrays and "quantiles" not in arrays:
        fail("%s is not a udvr model: no 'mean' or 'quantiles' array (its arrays: %s)"
             % (a.model, ", ".join(arrays) or "none"))
    color_array = "mean" if "mean" in arrays else "quantiles"

    # The full-resolution bounds (field data `bounds`, SPEC §7), else the grid's box.
    bounds = list(info.GetBounds())
    # Fetched from a second reader of the file with its point arrays switched off: the field data
    # comes without the arrays. (An ExtractSubset of one voxel of `reader` made the reader run
    # again for its extent: +212 MiB on each rank's VmRSS with a 216 MiB model.)
    meta = open_model()
    meta.PointArrayStatus = []
    field = servermanager.Fetch(meta)
    fb = field.GetFieldData().GetArray("bounds") if field else None
    if fb is not None and fb.GetNumberOfTuples() * fb.GetNumberOfComponents() == 6:
        bounds = [fb.GetComponent(i // fb.GetNumberOfComponents(), i % fb.GetNumberOfComponents())
                  for i in range(6)]
    Delete(meta)

    # paraview.simple resets the camera to the data's box at a view's first render; the camera
    # below is SPEC §5's over the full-resolution bounds, which differ for a downsampled model.
    paraview.simple._DisableFirstRenderCameraReset()
    view = CreateView("RenderView")
    view.ViewSize = [a.width, a.height]
    view.OrientationAxesVisibility = 0
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.Background = a.bg
    if hasattr(view, "UseFXAA"):
        view.UseFXAA = 0

    display = Show(reader, view)
    display.SetRepresentationType("Uncertain Volume")
    ColorBy(display, ("POINTS", color_array))
    lut = GetColorTransferFunction(color_array)
    pwf = GetOpacityTransferFunction(color_array)
    if a.tf:
        rgb, points = read_tf(a.tf)
        lut.AutomaticRescaleRangeMode = "Never"
        lut.ColorSpace = "RGB"
        lut.RGBPoints = separate_steps(rgb, 4)
        pwf.Points = separate_steps([v for i in range(0, len(points), 4)
                                     for v in (points[i], points[i + 1], 0.5, 0.0)], 4)
        if any(points[i + 2] != 0.5 or points[i + 3] != 0.0 for i in range(0, len(points), 4)):
            print("render.py: midpoint/sharpness other than 0.5/0 ignored, as udvr does",
                  file=sys.stderr)
    display.ScalarOpacityFunction = pwf
    display.UncertainModel = a.kind
    display.UncertainStep = a.step
    display.UncertainUnitDistance = a.unit_distance
    display.UncertainEarlyExit = a.early_exit
    display.UncertainRealizations = a.realizations
    display.UncertainSeed = a.seed
    display.UncertainUniformWidth = "minmax" if a.uniform_width == "minmax" else "variance"
    if a.tf2:
        display.UncertainTransferFunction2D = os.path.abspath(a.tf2)

    # SPEC §5's default camera (udvr's render/camera.cpp defaultCamera).
    c = [0.5 * (bounds[2 * i] + bounds[2 * i + 1]) for i in range(3)]
    radius = 0.5 * math.sqrt(sum((bounds[2 * i + 1] - bounds[2 * i]) ** 2 for i in range(3)))
    dist = radius / math.sin(math.radians(15.0)) / a.zoom
    az, el = math.radians(a.azimuth), math.radians(a.elevation)
    d = [math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)]
    view.CameraFocalPoint = c
    view.CameraPosition = [c[i] + dist * d[i] for i in range(3)]
    view.CameraViewUp = [-math.sin(az) * math.sin(el), math.cos(el), -math.cos(az) * math.sin(el)]
    view.CameraViewAngle = 30.0
    view.CameraParallelProjection = 0

    Render(view)
    if a.frames > 0:  # the render above was the warm-up (it read the data)
        times = []
        for _ in range(a.frames):
            start = time.perf_counter()
            view.StillRender()
            times.append(1000.0 * (time.perf_counter() - start))
        times.sort()
        import resource
        rank = servermanager.vtkProcessModule.GetProcessModule().GetPartitionId()
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        print("render.py: rank %d: %d frames of %dx%d: median %.1f ms, min %.1f ms; peak RSS %.0f MiB"
              % (rank, a.frames, a.width, a.height, times[len(times) // 2], times[0], peak))
    out = os.path.abspath(a.output)
    tmp = out + ".tmp.png"
    SaveScreenshot(tmp, view, ImageResolution=[a.width, a.height], TransparentBackground=0)
    if not os.path.isfile(tmp):
        fail("ParaView wrote no image to %s" % tmp)
    os.replace(tmp, out)
    return view, display


if __name__ == "__main__":
    main(sys.argv[1:])
