"""udvr: direct volume rendering of uncertain data (Athawale et al., TVCG 2021), for notebooks.

The compiled core is `udvr._udvr` (the same C++ library as the `udvr` command); this package
adds NumPy/xarray conversion, progress bars and matplotlib plots (`udvr.plot`) around it, with
no algorithm of its own. The pipeline mirrors the CLI (SPEC §8):

    model = udvr.build(ensemble)                 # (members, z, y, x) array or DataArray, a path
    tf = udvr.TransferFunction.from_paraview("tf.json")
    model.probe((10, 20, 30), model="quantile-range", tf=tf)    # what `probe --json` prints
    image = udvr.render(model, "quantile-range", tf, (256, 256))   # (H, W, 4) float32

Errors from the library carry the CLI's message: OSError for files, ValueError for values,
TypeError for the wrong kind of argument.
"""
import difflib
import json
import os
import tempfile
import warnings

import numpy as np

from . import _arrays, _udvr
from ._udvr import (Camera, Ensemble, Field, FileError, Grid, Model, RenderSettings,  # noqa: F401
                    TransferFunction, TransferFunction2D, UdvrError, experiment_names, generate,
                    members_model, model_from_field, model_names, models, perturb,
                    probe_options, read_ensemble, read_field, read_image, read_model,
                    read_png_text, read_transfer_function, render_options, set_threads,
                    visible_bounds, write_ensemble, write_field, write_model)
from ._udvr import __version__  # the release, as `udvr --version` prints it

__build__ = _udvr.__build__  # CPU target and vector width, as `udvr --version`

__all__ = ["Camera", "Ensemble", "Field", "Grid", "Model", "TransferFunction",
           "TransferFunction2D", "build", "difference_image", "experiment", "generate", "load",
           "members_model", "model_names", "models", "perturb", "probe_options", "read_png_text",
           "render", "render_options", "rmse", "__version__"]


# ---- progress ------------------------------------------------------------------------------

def _in_notebook():
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    ip = get_ipython()
    return ip is not None and "IPKernelApp" in getattr(ip, "config", {})


def _tqdm_bar(label, total):
    """A tqdm bar (a widget in notebooks where ipywidgets is installed, text otherwise)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # tqdm.auto's "IProgress not found"
            from tqdm.auto import tqdm
            return tqdm(total=total, desc=label)
    except ImportError:  # tqdm.notebook without ipywidgets: the text bar
        from tqdm import tqdm
        return tqdm(total=total, desc=label)


class _Progress:
    """progress=: a callable(done, total); True (a tqdm bar); "auto" (a tqdm bar in a Jupyter
    kernel when tqdm is installed, else nothing); None or False (nothing)."""

    def __init__(self, progress, label):
        self.bar = None
        self.callback = None
        if progress is None or progress is False:
            return
        if callable(progress):
            self.callback = progress
            return
        if progress == "auto" and not _in_notebook():
            return
        if progress not in (True, "auto"):
            raise TypeError(f"progress must be a callable(done, total), True, False, None or "
                            f"'auto', got {progress!r}")
        try:
            import tqdm  # noqa: F401
        except ImportError:
            if progress is True:
                raise ImportError("progress=True needs tqdm (apt install python3-tqdm)") from None
            return
        self.label = label
        self.callback = self._update

    def _update(self, done, total):
        if self.bar is None:
            self.bar = _tqdm_bar(self.label, total)
        self.bar.update(done - self.bar.n)

    def close(self):
        if self.bar is not None:
            self.bar.close()


# ---- build -----------------------------------------------------------------------------------

def _count(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    return int(value)


def build(data, quantiles=8, gmm=4, density=None, downsample=None, *,
          bandwidth="silverman", tail_eps=None, origin=None, spacing=None, var=None,
          member_dim=None, progress="auto", quantile_levels=None, nan="error"):
    """Per-voxel distribution models, as `udvr build` (SPEC §2): from a NumPy array of shape
    (members, z, y, x), a (z, y, x) field with downsample=K (its K³ bricks), an xarray
    DataArray (a member dim, or a field with downsample; its x, y, z coordinates give origin and
    spacing), or a file path (or a list of member files) as the CLI reads them.

    quantiles: q (0 skips), gmm: K (0 skips; lowered to the samples per voxel where fewer),
    density: "empirical" | "kde" (bandwidth "silverman" | "scott" | h, tail_eps) | "dequantized"
    (integer-typed data only: integer dtypes and integer files; each value spread uniformly over
    [v - step/2, v + step/2] of its quantisation step before the quantiles); None: the CLI's
    default, "kde" with downsample and "empirical" for ensembles. origin and
    spacing (x, y, z; world units) for arrays: default 0 and 1. quantile_levels: t_0 = 0 < … <
    t_q = 1, uneven levels of the boundaries (q from their count), as --quantile-levels. nan:
    "error" (NaN/Inf samples are a ValueError naming the first voxel and member) or "skip" (each
    voxel's statistics over its finite samples, at least 2 per voxel; NetCDF fill values count as
    NaN), as --nan. The GIL is released while it
    runs; progress: a callable(done, total), True for a tqdm bar, "auto" (a bar in notebooks). An
    exception the callable raises, and Ctrl-C (KeyboardInterrupt), stop the build and propagate.
    """
    if nan not in ("error", "skip"):
        raise ValueError(f"nan must be 'error' or 'skip', got {nan!r}")
    quantiles = _count(quantiles, "quantiles")
    gmm = _count(gmm, "gmm")
    if downsample is not None:
        downsample = _count(downsample, "downsample")
        if downsample < 2:
            raise ValueError(f"downsample must be K >= 2 (K^3 bricks), got {downsample}")
    if density is None:  # as `udvr build`: kde for K³ bricks, empirical for ensembles
        density = _udvr._default_density(downsample is not None)
    if not isinstance(density, str) or not isinstance(bandwidth, (str, int, float)):
        raise TypeError("density must be a string, bandwidth a string or a number")
    source = "python"
    value_step, value_type = 0.0, ""  # the input's quantisation step (dequantized)
    if _arrays.is_path(data) or (isinstance(data, (list, tuple)) and data
                                 and all(_arrays.is_path(p) for p in data)):
        paths = [os.fspath(p) for p in ([data] if _arrays.is_path(data) else data)]
        source = " ".join(paths) + (f" --downsample {downsample}" if downsample else "")
        if downsample:
            if len(paths) != 1:
                raise ValueError(f"--downsample takes one field, got {len(paths)} inputs")
            f = read_field(paths[0], var or "", nan == "skip")
            values, g = f.values, f.grid
            value_step, value_type = f.value_step, f.value_type
        else:
            e = read_ensemble(paths, var or "", member_dim or "", nan == "skip")
            values, g = e.values, e.grid
            value_step, value_type = e.value_step, e.value_type
        origin = g.origin if origin is None else origin
        spacing = g.spacing if spacing is None else spacing
    elif _arrays.is_dataarray(data):
        value_step, value_type = _arrays.value_step(data)
        values, o, s = _arrays.split_dataarray(data, member_dim, field=downsample is not None)
        origin = o if origin is None else origin
        spacing = s if spacing is None else spacing
        source = f"xarray {data.name}" if data.name is not None else "xarray"
    elif _arrays.is_dataset(data):
        raise TypeError("build takes one variable: pass ds['name'] (a DataArray), not a Dataset")
    else:
        value_step, value_type = _arrays.value_step(data)
        values = _arrays.real_array(data, "data", (3, 4))
        if values.ndim == 3 and downsample is None:
            raise ValueError(
                f"a {values.shape} array is one field: downsample=K models its K^3 bricks; an "
                "ensemble is a (members, z, y, x) array")
    if values.ndim == 4 and downsample is not None:
        raise ValueError(f"downsample reduces one (z, y, x) field; got a {values.shape} "
                         "ensemble: drop downsample to build from its members")
    origin = _arrays.vec3((0, 0, 0) if origin is None else origin, "origin")
    spacing = _arrays.vec3((1, 1, 1) if spacing is None else spacing, "spacing", positive=True)
    bar = _Progress(progress, "build")
    try:
        model, warns, info, dropped = _udvr._build(
            values, origin, spacing, downsample or 0, quantiles, gmm, density, str(bandwidth),
            tail_eps, gmm != 4, quantiles != 8, source, bar.callback,
            [] if quantile_levels is None else [float(t) for t in quantile_levels],
            value_step, value_type, nan)
    finally:
        bar.close()
    for w in warns:
        warnings.warn(w, stacklevel=2)
    if info:
        warnings.warn(f"build: {info}", stacklevel=2)
    if any(dropped):
        d = values.shape
        warnings.warn(f"build: {d[2]}x{d[1]}x{d[0]} is not a multiple of {downsample}; left "
                      f"out the trailing {dropped[0]},{dropped[1]},{dropped[2]} planes in x,y,z",
                      stacklevel=2)
    return model


def load(path, var=None):
    """A model .vti (from build or save) or any scalar field as a mean-only model, as `render`
    and `probe` read them."""
    if not _arrays.is_path(path):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    return _udvr._read_model_or_field(os.fspath(path), var or "")


def _save(self, path):
    """Write the model as a .vti (SPEC §7), as `udvr build -o` does."""
    if not _arrays.is_path(path):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    path = os.fspath(path)
    if not path.lower().endswith(".vti"):
        raise ValueError(f"path must name a .vti file (a model is written as VTK ImageData), "
                         f"got '{path}'")
    write_model(path, self)


def _as_members(x, name="model"):
    """The ensemble x for model 'members' (the TF averaged over the members, as `udvr render
    --model members`): a udvr.Ensemble, a (members, z, y, x) array or DataArray, an ensemble's
    path (a .nc with a member dimension, a quoted glob) or a list of member paths."""
    if isinstance(x, Model):
        if x.member_count == 0:
            raise ValueError(f"model 'members' averages the TF over an ensemble's members; {name} "
                             "is a model or field without them: pass the ensemble (a "
                             "udvr.Ensemble, a (members, z, y, x) array or DataArray, or its "
                             "path)")
        return x
    if isinstance(x, Ensemble):
        return members_model(x)
    if _arrays.is_path(x):
        return members_model(read_ensemble([os.fspath(x)]))
    if isinstance(x, (list, tuple)) and x and all(_arrays.is_path(p) for p in x):
        return members_model(read_ensemble([os.fspath(p) for p in x]))
    if _arrays.is_dataarray(x):
        values, origin, spacing = _arrays.split_dataarray(x, field=False)
        return members_model(Ensemble(values, origin, spacing))
    if isinstance(x, np.ndarray):
        return members_model(Ensemble(x))
    raise TypeError(f"model 'members' needs an ensemble: a udvr.Ensemble, a (members, z, y, x) "
                    f"array or DataArray, or its path; {name} is a {type(x).__name__}")


# The model table's rows by name (udvr.models(): src/udvr/classify/model_rows.h).
_MODEL_ROWS = {row["name"]: row for row in _udvr.models()}


def _reads_members(model_name):
    """Whether the model's row reads an ensemble's members themselves (its arrays name
    'members'), not a model file's arrays."""
    row = _MODEL_ROWS.get(model_name)
    return row is not None and "members" in row["arrays"]


def _as_model(x, name="model", model_name="mean"):
    """A Model; a Field, a (z, y, x) array or a 3-dim DataArray as a mean-only model (ground
    truth); a path as load(); for a model that reads the members (its row's arrays: 'members')
    an ensemble (_as_members)."""
    if _reads_members(model_name):
        return _as_members(x, name)
    if isinstance(x, Model):
        return x
    if isinstance(x, Ensemble):
        raise TypeError(f"{name} is a udvr.Ensemble: model 'members' renders its members' TF "
                        f"average; udvr.build(ensemble) models it")
    if isinstance(x, Field):
        return model_from_field(x)
    if _arrays.is_path(x):
        return load(x)
    if _arrays.is_dataarray(x):
        values, origin, spacing = _arrays.split_dataarray(x, field=True)
        return model_from_field(Field(values, origin, spacing))
    if isinstance(x, (np.ndarray, list, tuple)):
        return model_from_field(Field(_arrays.real_array(x, name, 3)))
    raise TypeError(f"{name} must be a udvr.Model, a Field, a (z, y, x) array, a DataArray or "
                    f"a path, got {type(x).__name__}")


# ---- xarray ------------------------------------------------------------------------------------

_SCALARS = ("mean", "stddev", "min", "max")
_COMPONENT_DIMS = {"quantiles": "quantile_boundary", "iqr": "iqr_boundary", "gmm": "gmm_parameter"}


def _to_xarray(self):
    """An xarray.Dataset with the arrays of SPEC §7 (mean, stddev, min, max over (z, y, x);
    quantiles, iqr, gmm with a trailing component dim) as views of the model's memory, the
    grid as x, y, z coordinates and the field data as attributes."""
    import xarray as xr
    coords = _coords(self.grid)
    data = {}
    for name in _SCALARS + tuple(_COMPONENT_DIMS):
        values = getattr(self, name)
        if values is not None:
            dims = ("z", "y", "x") + ((_COMPONENT_DIMS[name],) if name in _COMPONENT_DIMS else ())
            data[name] = (dims, values)
    attrs = {"quantile_count": self.quantile_count, "quantile_levels": self.quantile_levels,
             "gmm_components": self.gmm_components,
             "density": self.density, "bandwidth": self.bandwidth,
             "bandwidth_rule": self.bandwidth_rule, "tail_eps": self.tail_eps,
             "samples_per_voxel": self.samples_per_voxel, "downsample": self.downsample,
             "bounds": list(self.bounds), "full_res_min_spacing": self.full_res_min_spacing,
             "source": self.source}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _coords(g):
    """x, y, z coordinate values of a grid's points (world units)."""
    return {name: g.origin[a] + g.spacing[a] * np.arange(g.dims[a]) for a, name in enumerate("xyz")}


def _ensemble_to_xarray(self):
    """The members as an xarray.DataArray (member, z, y, x) with x, y, z coordinates (a copy),
    what udvr.build takes back."""
    import xarray as xr
    return xr.DataArray(self.values, dims=("member", "z", "y", "x"), coords=_coords(self.grid),
                        name=self.name or "value")


def _field_to_xarray(self):
    """The field as an xarray.DataArray (z, y, x) with x, y, z coordinates (a copy)."""
    import xarray as xr
    return xr.DataArray(self.values, dims=("z", "y", "x"), coords=_coords(self.grid),
                        name=self.name or "value")


def _from_xarray(ds):
    """A Model from an xarray.Dataset as to_xarray makes it (at least a `mean` variable over
    z, y, x; its coordinates give origin and spacing, its attributes the field data)."""
    if not _arrays.is_dataset(ds):
        raise TypeError(f"from_xarray takes an xarray.Dataset, got {type(ds).__name__}")
    if "mean" not in ds.data_vars:
        raise ValueError("the Dataset has no 'mean' variable (SPEC §7 names: mean, stddev, min, "
                         "max, quantiles, iqr, gmm)")
    spatial = [d for d in ("z", "y", "x") if d in ds["mean"].dims]
    if len(spatial) != 3:
        spatial = list(ds["mean"].dims)
    origin, spacing = _arrays.geometry_of(ds["mean"], spatial)
    arrays = {}
    for name in _SCALARS + tuple(_COMPONENT_DIMS):
        if name in ds.data_vars:
            v = ds[name]
            order = spatial + [d for d in v.dims if d not in spatial]
            arrays[name] = _arrays.real_array(v.transpose(*order).values, name)
    a = ds.attrs
    bounds = a.get("bounds")
    full = a.get("full_res_min_spacing")
    return Model(arrays.pop("mean"), **arrays, origin=origin, spacing=spacing,
                 bounds=None if bounds is None else [float(b) for b in np.ravel(bounds)],
                 full_res_min_spacing=None if full is None else float(full),
                 downsample=int(a.get("downsample", 0)),
                 samples_per_voxel=int(a.get("samples_per_voxel", 0)),
                 density=str(a.get("density", "empirical")), source=str(a.get("source", "xarray")),
                 bandwidth=float(a.get("bandwidth", 0.0)),
                 bandwidth_rule=str(a.get("bandwidth_rule", "")),
                 tail_eps=float(a.get("tail_eps", 0.0)),
                 quantile_levels=[float(t) for t in np.ravel(a.get("quantile_levels", []))]
                 if "quantiles" in arrays else [])


# ---- transfer functions ------------------------------------------------------------------------

def _tf_from_paraview(source):
    """A 1D TF from ParaView JSON: a file path, JSON text, or the parsed list/dict."""
    if isinstance(source, (dict, list)):
        return TransferFunction.from_json(json.dumps(source), "transfer function")
    if isinstance(source, str) and source.lstrip()[:1] in ("[", "{"):
        return TransferFunction.from_json(source, "transfer function JSON")
    if _arrays.is_path(source):
        return TransferFunction.read(os.fspath(source))
    raise TypeError(f"from_paraview takes a path, JSON text or a parsed list/dict, got "
                    f"{type(source).__name__}")


def _tf_save(self, path, name="udvr"):
    """Write ParaView JSON (what `--save-tf` writes)."""
    with open(path, "w") as f:
        f.write(self.to_json(name))


def _tf_plot(self, ax=None, range=None):  # noqa: A002  (matplotlib's word)
    """The colour strip and opacity curve (udvr.plot.transfer_function)."""
    from . import plot
    return plot.transfer_function(self, ax=ax, range=range)


def _resolve_tf(tf, model, tf_range=None):
    """(the TF, whether the user gave one): None or a preset name gives the preset over the
    model's means as the CLI without --tf (0.5–99.5th percentiles, or tf_range)."""
    presets = TransferFunction.preset_names()
    if tf is None or (isinstance(tf, str) and tf in presets and not os.path.exists(tf)):
        return TransferFunction.preset_for(tf or presets[0], model, tf_range), False
    if tf_range is not None:
        raise ValueError("tf_range spreads a preset; the TF given is not one")
    if isinstance(tf, (TransferFunction, TransferFunction2D)):
        return tf, True
    if isinstance(tf, str) and not os.path.exists(tf) and not tf.lower().endswith(".json") \
            and tf.lstrip()[:1] not in ("[", "{"):
        raise ValueError(f"tf '{tf}' is neither a file nor a preset (presets: "
                         f"{', '.join(presets)})")
    return _tf_from_paraview(tf), True


# ---- probe -------------------------------------------------------------------------------------

def _probe_full(self, point=None, model="mean", tf=None, *, world=None, second=None,
                tf_range=None, **options):
    _udvr._check_model(model)
    given = _option_texts(options, probe_options(), "probe")
    if (point is None) == (world is None):
        raise ValueError("give the point as point=(i, j, k) (index) or world=(x, y, z), one of "
                         "them")
    if world is not None:
        w = _arrays.vec3(world, "world")
        point = _udvr.index_from_world(self.grid, w, "world ({:g}, {:g}, {:g})".format(*w))
    point = _arrays.vec3(point, "point")
    tf, _ = _resolve_tf(tf, self, tf_range)
    _udvr._require_tf2_for_second(second is not None, isinstance(tf, TransferFunction2D))
    if second is not None:
        text, dist = _udvr._probe_bivariate(self, _as_model(second, "second", model), model, tf,
                                            point, given)
    else:
        text, dist = _udvr._probe(self, model, tf, point, given)
    return json.loads(text), dist, tf


def _probe(self, point=None, model="mean", tf=None, *, world=None, second=None, tf_range=None,
           **options):
    """The distribution and expected TF at one point, as the dict `udvr probe --json` prints
    (SPEC §8): model, point (index space), world, grid_dims, expected_rgba ([E[αr], E[αg],
    E[αb], E[α]]), value and the model's parameters (mean/stddev, boundaries, …).

    point: index coordinates (i, j, k), or world=(x, y, z); model: a name of udvr.model_names();
    tf: a TransferFunction (or TransferFunction2D), a ParaView JSON path, a preset name, or None
    (the CLI's default preset over the model's means); second: the model giving a 2D TF's y
    (model 'members': an ensemble, as the first).
    options: every classification option of `udvr probe` by its name with '_' for '-' —
    uniform_width, … (udvr.probe_options() lists them with their defaults and help; None: the
    default); the same code parses and checks them as the CLI's flags.
    """
    return _probe_full(self, point, model, tf, world=world, second=second, tf_range=tf_range,
                       **options)[0]


# ---- render, metrics, experiments ------------------------------------------------------------

def _size(size):
    if isinstance(size, (int, np.integer)) and not isinstance(size, bool):
        size = (int(size), int(size))
    try:
        w, h = (int(s) for s in size)
    except (TypeError, ValueError):
        raise TypeError(f"size must be N or (width, height), got {size!r}") from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise ValueError(f"size {w}x{h}: each side must lie in [1, 16384]")
    return w, h


def _option_text(name, value):
    """A keyword's value as the CLI's flag takes it: numbers as typed, sequences comma-joined,
    a (width, height) size as WxH, booleans as 1/0."""
    if name == "size":  # N or (width, height), as before the option tables
        w, h = _size(value)
        return f"{w}x{h}"
    if isinstance(value, (bool, np.bool_)):
        return "1" if value else "0"
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    try:
        return ",".join(_option_text(name + " item", v) for v in value)
    except TypeError:
        raise TypeError(f"{name} must be a number, text or a sequence of numbers, got "
                        f"{type(value).__name__}") from None


def _option_texts(options, table, function):
    """[(option name, text)] for the options of `table` (udvr.render_options() or
    udvr.probe_options() of `function`); None leaves an option at its default."""
    known = {row[0] for row in table}
    out = []
    for name, value in options.items():
        if name not in known:
            near = difflib.get_close_matches(name, sorted(known), n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise TypeError(f"{function}() got an unexpected keyword argument '{name}'{hint} "
                            f"(the options are udvr.{function}_options(): "
                            f"{', '.join(sorted(known))})")
        if value is not None:
            out.append((name, _option_text(name, value)))
    return out


def _render_options(options):
    """_option_texts of udvr.render's options; skip_empty=False is kept as the old spelling of
    no_skip=True."""
    options = dict(options)
    if "skip_empty" in options:
        options["no_skip"] = not options.pop("skip_empty")
    return _option_texts(options, render_options(), "render")


def render(model, model_name="mean", tf=None, size=None, camera=None, *, second=None,
           tf_range=None, **options):
    """Ray-cast a model (or a field: a Field, (z, y, x) array, DataArray or path) with noise
    model `model_name`, as `udvr render` (SPEC §5): an (H, W, 4) float32 RGBA array (straight
    colour over the background; the values `--float` writes). The GIL is released while it runs;
    Ctrl-C stops it with KeyboardInterrupt.

    size: N or (width, height) (None: `udvr render`'s default). camera: a udvr.Camera; else
    SPEC §5's default camera (azimuth, elevation and zoom: their keywords, defaults as
    udvr.render_options() says) whatever the TF, and with view=(+x|-x|+y|-y|+z|-z) or
    frame="visible" a camera framing the visible voxels, as the CLI.
    options: every option of `udvr render` by its name with '_' for '-' — view, azimuth,
    elevation, zoom, view_angle, parallel_scale, step, unit_distance, early_exit, background,
    no_skip, uniform_width, realizations, seed, jitter, force, … (udvr.render_options() lists
    them with their help); the same code parses and checks them as the CLI's flags.
    """
    _udvr._check_model(model_name)
    model = _as_model(model, model_name=model_name)
    tf, _ = _resolve_tf(tf, model, tf_range)
    s = _udvr._render_settings(model, tf, _render_options(dict(options, size=size)))
    if camera is not None:
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a udvr.Camera, got {type(camera).__name__}")
        s.camera = camera
    _udvr._require_tf2_for_second(second is not None, isinstance(tf, TransferFunction2D))
    if second is not None:
        return _udvr._render_bivariate(model, _as_model(second, "second", model_name), model_name,
                                       tf, s)
    return _udvr._render(model, model_name, tf, s)


def _image(a, name):
    return _arrays.real_array(a, name, 3)


def rmse(model, truth):
    """SPEC §6 between two (H, W, 4) or (H, W, 3) images, as `udvr compare` prints it."""
    return _udvr.rmse(_image(model, "model image"), _image(truth, "truth image"))


def difference_image(model, truth, max_diff=0.0):
    """The blue-yellow difference image of `udvr compare --diff`, (H, W, 4) float32."""
    return _udvr.difference_image(_image(model, "model image"), _image(truth, "truth image"),
                                  float(max_diff))


def experiment(name, quick=True, out=None, *, dims=0, members=0, image_size=0, realizations=0,
               tf_dir=None, data_dir=None, log=False):
    """Run one of the paper's experiments as `udvr experiment NAME -o OUT [--quick]` (the GIL
    released): returns (table, figure), the results table as a pandas DataFrame when pandas is
    installed (else a list of dicts, the rows of results.json) and the path of its figure.png;
    "all" runs every experiment and returns all their rows (no figure). out: the output folder
    (default: a new temporary folder); dims, members, image_size, realizations: smaller runs.
    """
    if name != "all" and name not in experiment_names():
        raise ValueError(f"unknown experiment '{name}' (expected one of "
                         f"{', '.join(experiment_names())})")
    out = tempfile.mkdtemp(prefix=f"udvr-{name}-") if out is None else os.fspath(out)
    results = _udvr._experiment(name, out, bool(quick), os.fspath(tf_dir or ""),
                                os.fspath(data_dir or ""), dims, members, image_size,
                                realizations, bool(log))
    # "all": every experiment's rows (their `experiment` column tells them apart); no figure.
    rows = [row for r in results for row in r["rows"]]
    figure = os.path.join(results[0]["dir"], "figure.png") if len(results) == 1 else ""
    try:
        import pandas as pd
        rows = pd.DataFrame(rows)
    except ImportError:
        pass
    return rows, (figure if figure and os.path.exists(figure) else None)


Ensemble.to_xarray = _ensemble_to_xarray
Field.to_xarray = _field_to_xarray
Model.save = _save
Model.to_xarray = _to_xarray
Model.from_xarray = staticmethod(_from_xarray)
Model.probe = _probe


def _model_repr(self):
    g = self.grid
    parts = ["x".join(map(str, g.dims)) + " voxels"]
    if self.quantile_count:
        even = np.allclose(self.quantile_levels, np.linspace(0, 1, self.quantile_count + 1))
        parts.append(f"q={self.quantile_count}" + ("" if even else " (uneven levels)"))
    if self.gmm_components:
        parts.append(f"GMM K={self.gmm_components}")
    parts.append(self.density)
    if self.samples_per_voxel:
        parts.append(f"{self.samples_per_voxel} samples per voxel")
    return "<udvr.Model " + ", ".join(parts) + ">"


Model.__repr__ = _model_repr
TransferFunction.from_paraview = staticmethod(_tf_from_paraview)
TransferFunction.save = _tf_save
TransferFunction.plot = _tf_plot
