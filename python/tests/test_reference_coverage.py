"""Every row of the model table (udvr.models(), src/udvr/classify/model_rows.h) is guarded by
the independent references, for every TF kind it renders with, at probe and image level; a row
added without its reference fails here (docs/architecture.md, "Adding a model").

The references name what they evaluate per CLI name (reference.MODELS, reference2d.MODELS,
reference_bivariate.MODELS) or why they do not (their NO_REFERENCE); the tests take their lists
of models from the table (model_table.py) and exempt a model from a check only through a
documented list ({name: why}) that must hold rows of the table and nothing else."""
import pytest

import model_table
import reference
import reference2d
import reference_bivariate
import test_reference2d_cli
import test_reference_bivariate
import test_reference_members
import test_reference_probe
import test_reference_render

REFERENCES = {"1d": reference, "2d": reference2d, "bivariate": reference_bivariate}


def test_the_table_is_exposed_with_its_tf_kinds():
    rows = model_table.rows()
    assert [r["name"] for r in rows] == model_table.udvr.model_names()
    for r in rows:
        assert r["tf_kinds"], r["name"]
        assert set(r["tf_kinds"]) <= set(model_table.TF_KINDS), r
        assert r["arrays"], r["name"]
        assert r["probe"] != r["realizations"], r  # a kernel, or realizations (gmm-mc)


@pytest.mark.parametrize("tf_kind", model_table.TF_KINDS)
def test_every_row_has_a_reference_or_says_why_not(tf_kind):
    module = REFERENCES[tf_kind]
    table = set(model_table.names(tf_kind))
    assert table, tf_kind
    model_table.check_exemptions(module.NO_REFERENCE, tf_kind,
                                 module.__name__ + ".NO_REFERENCE")
    named = set(module.MODELS)
    missing = sorted(table - named - set(module.NO_REFERENCE))
    assert not missing, ("models of the table with a %s TF that %s.py has no reference for: %s "
                         "(add it to %s.MODELS, or to NO_REFERENCE with why)" % (
                             tf_kind, module.__name__, missing, module.__name__))
    stale = sorted(named - table)
    assert not stale, "%s.MODELS names %s, not models with a %s TF" % (module.__name__, stale,
                                                                       tf_kind)
    both = sorted(named & set(module.NO_REFERENCE))
    assert not both, both


def test_the_exemption_and_tolerance_lists_name_rows_of_the_table():
    model_table.check_exemptions(test_reference_render.SMALL_IMAGE, "1d",
                                 "test_reference_render.SMALL_IMAGE")
    model_table.check_exemptions(test_reference_bivariate.PROBE_ONLY, "bivariate",
                                 "test_reference_bivariate.PROBE_ONLY")
    for what, tols, tf_kind in (("FAST_TOL_1D", model_table.FAST_TOL_1D, "1d"),
                                ("test_reference2d_cli.FAST_TOL", test_reference2d_cli.FAST_TOL,
                                 "2d")):
        unknown = sorted(set(tols) - set(model_table.names(tf_kind)))
        assert not unknown, (what, unknown)
    assert set(test_reference2d_cli.TOL_UNIFORM_MC) >= set(reference2d.NO_REFERENCE)


def test_1d_every_row_is_probed_and_imaged_against_the_reference():
    members = set(test_reference_members.KINDS)
    realizations = set(test_reference_render.REALIZATIONS)
    assert realizations == set(model_table.names("1d", realizations=True))
    # Probe: every row with a distribution at a point.
    probed = set(test_reference_probe.MODELS) | members
    assert probed == set(model_table.names("1d", probe=True))
    # Image: every row, at 12×9 (KINDS) or 7×5 (SMALL_IMAGE), gmm-mc by realizations; each
    # small-image one probed too.
    imaged = (set(test_reference_render.KINDS) | set(test_reference_render.SMALL_IMAGE)
              | realizations | members)
    assert imaged | set(reference.NO_REFERENCE) == set(model_table.names("1d"))
    assert not set(test_reference_render.KINDS) & set(test_reference_render.SMALL_IMAGE)
    assert set(test_reference_render.SMALL_IMAGE) <= probed


def test_2d_every_row_is_probed_and_imaged_against_a_reference():
    table = set(model_table.names("2d"))
    kinds = set(test_reference2d_cli.KINDS)
    # Against reference2d at probe and image level, or (NO_REFERENCE) against Monte Carlo.
    assert kinds | set(reference2d.NO_REFERENCE) == table
    assert not (table - set(model_table.model_file_names("2d"))), "a 2D model without a file"


def test_bivariate_every_row_is_probed_and_imaged_against_the_reference():
    table = set(model_table.names("bivariate"))
    kinds = set(test_reference_bivariate.KINDS)
    members = set(test_reference_bivariate.MEMBER_KINDS)
    assert kinds | members | set(reference_bivariate.NO_REFERENCE) == table
    rendered = set(test_reference_bivariate.RENDER_KINDS) | members
    probe_only = set(test_reference_bivariate.PROBE_ONLY)
    assert rendered | probe_only | set(reference_bivariate.NO_REFERENCE) == table
    assert probe_only <= kinds  # probed at TOL
