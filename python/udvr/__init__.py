"""udvr: direct volume rendering of uncertain data (Athawale et al., TVCG 2021), for notebooks.

The compiled core is `udvr._udvr` (the same C++ library as the `udvr` command); this package
adds NumPy/xarray conversion and matplotlib plots around it, with no algorithm of its own.
"""
from . import _udvr
from ._udvr import *  # noqa: F401,F403  generate, perturb, readers and writers, Model, render …
from ._udvr import __version__  # the release, as `udvr --version` prints it

__build__ = _udvr.__build__  # CPU target and vector width, as `udvr --version`
