"""ParaView's model menu against the model table (src/udvr/classify/model_rows.h).

The plugin's XML (udvr.xml, written from paraview/plugin/UdvrParaView/udvr.xml.in by
udvr_paraview_menu) names each model and stores its ModelKind as an integer, the row's index in
UDVR_MODEL_ROWS. A row inserted in the middle, or an entry named wrongly, would make ParaView
render another model than it shows. The rows are read from the header's text, independently of
the C++ that expands them.
"""
import pathlib
import re
import subprocess
import xml.etree.ElementTree as ET

import pytest

from conftest import UDVR_BINARY

ROOT = pathlib.Path(__file__).resolve().parents[2]
TEMPLATE = ROOT / "paraview/plugin/UdvrParaView/udvr.xml.in"


def table_rows():
    text = (ROOT / "src/udvr/classify/model_rows.h").read_text()
    body = text[text.index("#define UDVR_MODEL_ROWS(X)"):]
    body = body[:body.index("// clang-format on")]
    enumerators = re.findall(r"X\((\w+),", body)
    names = re.findall(r'\.name = "([^"]+)"', body)
    assert len(enumerators) == len(names) > 0, (enumerators, names)
    return enumerators, names


def test_rows_have_one_name_each_and_unique_enumerators():
    enumerators, names = table_rows()
    assert len(set(enumerators)) == len(enumerators)
    assert len(set(names)) == len(names)


def menu_tool():
    tool = UDVR_BINARY.parent / "udvr_paraview_menu"
    if not tool.is_file():
        pytest.skip(f"udvr_paraview_menu not built beside {UDVR_BINARY}")
    return tool


def generated_entries(xml_path):
    tree = ET.parse(xml_path)
    entries = [
        (e.get("text"), int(e.get("value")))
        for prop in tree.iter("IntVectorProperty")
        if prop.get("name") == "UncertainModel"
        for e in prop.iter("Entry")
    ]
    docs = [
        d.text
        for prop in tree.iter("IntVectorProperty")
        if prop.get("name") == "UncertainModel"
        for d in prop.iter("Documentation")
    ]
    return entries, docs


def test_paraview_menu_is_generated_from_every_row_but_the_members(tmp_path):
    enumerators, names = table_rows()
    out = tmp_path / "udvr.xml"
    subprocess.run([str(menu_tool()), str(TEMPLATE), str(out)], check=True)
    entries, docs = generated_entries(out)
    # Every row ParaView can render (a model file holds no members) once, by its row index.
    want = [(name, index) for index, name in enumerate(names) if name != "members"]
    assert entries == want
    assert len(docs) == 1
    for name in names:
        assert (name + ":" in docs[0]) == (name != "members"), name
    # The rest of the template is kept: every other property of the representation.
    template_props = re.findall(r'<(?:Int|Double)VectorProperty name="(\w+)"', TEMPLATE.read_text())
    got_props = [p.get("name") for p in ET.parse(out).iter()
                 if p.tag in ("IntVectorProperty", "DoubleVectorProperty")]
    assert got_props == template_props


def test_paraview_menu_refuses_a_template_without_its_markers(tmp_path):
    bad = tmp_path / "bad.xml.in"
    bad.write_text(TEMPLATE.read_text().replace("@UDVR_MODEL_HELP@", ""))
    out = tmp_path / "udvr.xml"
    r = subprocess.run([str(menu_tool()), str(bad), str(out)], capture_output=True, text=True)
    assert r.returncode == 1
    assert "@UDVR_MODEL_HELP@" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not out.exists() and not (tmp_path / "udvr.xml.tmp").exists()


def test_the_built_plugin_carries_the_generated_menu(tmp_path):
    built = UDVR_BINARY.parent / "paraview/plugin/UdvrParaView/udvr.xml"
    if not built.is_file():
        pytest.skip("the ParaView plugin is not built here")
    out = tmp_path / "udvr.xml"
    subprocess.run([str(menu_tool()), str(TEMPLATE), str(out)], check=True)
    assert built.read_text() == out.read_text()
