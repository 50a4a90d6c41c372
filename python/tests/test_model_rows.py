"""ParaView's model menu against the model table (src/udvr/classify/model_rows.h).

The plugin's XML (paraview/plugin/UdvrParaView/udvr.xml) names each model and stores its
ModelKind as an integer, the row's index in UDVR_MODEL_ROWS. A row inserted in the middle, or an
entry renamed on one side only, would make ParaView render another model than it shows. The
rows are read from the header's text, independently of the C++ that expands them.
"""
import pathlib
import re
import xml.etree.ElementTree as ET

ROOT = pathlib.Path(__file__).resolve().parents[2]


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


def test_paraview_entries_name_the_rows_of_their_values():
    _, names = table_rows()
    tree = ET.parse(ROOT / "paraview/plugin/UdvrParaView/udvr.xml")
    entries = [
        (e.get("text"), int(e.get("value")))
        for prop in tree.iter("IntVectorProperty")
        if prop.get("name") == "UncertainModel"
        for e in prop.iter("Entry")
    ]
    assert entries, "no UncertainModel entries"
    for text, value in entries:
        assert 0 <= value < len(names), (text, value)
        assert names[value] == text, "entry %r has value %d, the row of %r" % (
            text, value, names[value])
