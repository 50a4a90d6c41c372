"""The model table as the library gives it (udvr.models(): the rows of
src/udvr/classify/model_rows.h), for the reference tests: their lists of models come from here,
not by hand, so a new row is checked (or fails test_reference_coverage.py) without editing them."""
import pytest

udvr = pytest.importorskip("udvr")

TF_KINDS = ("1d", "2d", "bivariate")

# The 1D fast forms, held to their documented error instead of the SPEC's 1e−4: `uniform` (alias
# `uniform-fast`), the box spline's fast form, 3.6e−4 (docs/models.md "Error against the exact
# uniform": the largest over 2·10⁶ random points). Rows of the table
# (test_reference_coverage.py).
FAST_TOL_1D = {"uniform": 3.6e-4, "uniform-fast": 3.6e-4}


def rows():
    return udvr.models()


def names(tf_kind, probe=None, members=None, realizations=None):
    """The names of the rows that render with `tf_kind` ('1d', '2d', 'bivariate'), in table
    order; probe / members / realizations: only rows with (True) or without (False) a
    distribution at a point, the ensemble's members as their array, realizations (gmm-mc)."""
    assert tf_kind in TF_KINDS, tf_kind
    out = []
    for r in rows():
        if tf_kind not in r["tf_kinds"]:
            continue
        if probe is not None and r["probe"] != probe:
            continue
        if members is not None and ("members" in r["arrays"]) != members:
            continue
        if realizations is not None and r["realizations"] != realizations:
            continue
        out.append(r["name"])
    return out


def model_file_names(tf_kind, probe=None):
    """names() of the rows that read a model file's arrays with a per-sample kernel: what the
    reference tests render and probe from a written model (not members, not gmm-mc)."""
    return names(tf_kind, probe=probe, members=False, realizations=False)


def check_exemptions(exempt, tf_kind, what):
    """An exemption list {name: why} of a reference test: every key a row of the table that
    renders with `tf_kind`, every reason written out."""
    known = set(names(tf_kind))
    unknown = sorted(set(exempt) - known)
    assert not unknown, "%s names %s, not models of the table with a %s TF (%s)" % (
        what, unknown, tf_kind, sorted(known))
    for name, why in exempt.items():
        assert isinstance(why, str) and len(why) > 20, "%s: say why %s is exempt" % (what, name)
