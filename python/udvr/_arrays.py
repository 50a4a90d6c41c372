"""Checks and conversions between NumPy/xarray and the compiled core: dtypes, shapes, geometry.

Arrays reach C++ as C-ordered float32 (z, y, x fastest last, SPEC §1); any real dtype is
converted (a copy only where the dtype or order differs), complex, object, string and date
arrays are refused with TypeError before any work starts.
"""
import os

import numpy as np

from . import _udvr

# The member dimension names the NetCDF reader looks for, in its order (io/netcdf_io.cpp).
MEMBER_DIMS = ("member", "ensemble", "realization", "number")
SPATIAL_DIMS = ("z", "y", "x")


def is_path(x):
    return isinstance(x, (str, bytes, os.PathLike))


def is_dataarray(x):
    return type(x).__name__ == "DataArray" and hasattr(x, "dims") and hasattr(x, "coords")


def is_dataset(x):
    return type(x).__name__ == "Dataset" and hasattr(x, "data_vars")


def real_array(a, name, ndim=None):
    """`a` as a C-ordered float32 array; TypeError for non-real dtypes, ValueError for the wrong
    number of dimensions (`ndim`: an int or a tuple of the accepted ones)."""
    if is_path(a) or a is None:
        raise TypeError(f"{name} must be an array of real numbers, got {type(a).__name__}")
    arr = np.asarray(a)
    if arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must hold real numbers (bool, integer or float), got dtype "
                        f"{arr.dtype}" + (": take .real or abs() first" if arr.dtype.kind == "c"
                                          else ""))
    if ndim is not None:
        accepted = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in accepted:
            want = " or ".join(str(n) for n in accepted)
            raise ValueError(f"{name} must have {want} dimensions, got shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float32)


def value_step(a):
    """(quantisation step, type name) of an array's values, as the C++ readers give them for
    files: 1 for integer dtypes, 0 for the rest (floats; bool is not a quantised number)."""
    dt = getattr(a, "dtype", None)
    if dt is None:
        dt = np.asarray(a).dtype
    dt = np.dtype(dt)
    return (1.0 if dt.kind in "iu" else 0.0), str(dt)


def vec3(v, name, positive=False):
    """Three finite floats (x, y, z)."""
    try:
        t = tuple(float(c) for c in v)
    except TypeError:
        raise TypeError(f"{name} must be three numbers (x, y, z), got {v!r}") from None
    if len(t) != 3 or not all(np.isfinite(t)):
        raise ValueError(f"{name} must be three finite numbers (x, y, z), got {v!r}")
    if positive and not all(c > 0 for c in t):
        raise ValueError(f"{name} must be positive, got {v!r}")
    return t


def axis_geometry(coords, name):
    """(origin, spacing) of an axis from its coordinate values, by the NetCDF reader's rule
    (finite, increasing, evenly spaced; ValueError otherwise)."""
    c = np.asarray(coords, dtype=np.float64).ravel()
    return _udvr._regular_axis(c.tolist(), f"coordinate {name}")


def geometry_of(da, spatial):
    """origin, spacing (x, y, z) of a DataArray from the coordinates of its spatial dims
    (z, y, x order); origin 0 and spacing 1 where a dim has no coordinate."""
    origin, spacing = [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]
    for axis, dim in zip((2, 1, 0), spatial):
        if dim in da.coords:
            origin[axis], spacing[axis] = axis_geometry(da.coords[dim].values, dim)
    return origin, spacing


def split_dataarray(da, member_dim=None, field=False):
    """(values, origin, spacing) of an xarray DataArray: (members, z, y, x) for an ensemble
    (the member dim by `member_dim` or by name as the NetCDF reader), (z, y, x) for a field.
    Dims named z, y, x are put in that order; otherwise the last three dims are (z, y, x)."""
    dims = list(da.dims)
    if field:
        if len(dims) != 3:
            raise ValueError(f"a field DataArray must have 3 dims (z, y, x), got {tuple(dims)}")
        member = None
    else:
        if member_dim is not None:
            if member_dim not in dims:
                raise ValueError(f"member_dim '{member_dim}' is not a dim of the DataArray "
                                 f"{tuple(dims)}")
            member = member_dim
        else:
            member = next((d for d in MEMBER_DIMS if d in dims), None)
            if member is None:
                raise ValueError(
                    f"the DataArray {tuple(dims)} has no member dimension (one of "
                    f"{', '.join(MEMBER_DIMS)}); name it with member_dim=, or pass "
                    "downsample=K to model one field's K^3 bricks")
        if len(dims) != 4:
            raise ValueError(f"an ensemble DataArray must have 4 dims (member, z, y, x), got "
                             f"{tuple(dims)}")
    rest = [d for d in dims if d != member]
    spatial = list(SPATIAL_DIMS) if set(SPATIAL_DIMS) <= set(rest) else rest
    order = ([member] if member else []) + spatial
    da = da.transpose(*order)
    origin, spacing = geometry_of(da, spatial)
    return real_array(da.values, "the DataArray", 3 if field else 4), origin, spacing
