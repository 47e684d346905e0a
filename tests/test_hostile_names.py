"""Text from a user's file or command line, written into code or markup, stays text (issue 30).

One test per writer, each with the same hostile names (quotes, triple quotes, line breaks, ``</script>``, ``&``,
``%``, backslashes, non-ASCII, control characters, an undecodable file name's lone surrogate). Each checks the
output as its reader does: Python is compiled and run in a fresh process (the payload must not run), C is
compiled (and the strings printed back byte for byte), XML is parsed (the text intact), HTML is parsed (no tag
but the page's own), Markdown has no live markup, CSV and JSON read back to the same text.
"""
from __future__ import annotations

import ast
import contextlib
import csv
import html.parser
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote
from xml.etree import ElementTree as ET

import pytest
from conftest import require_or_skip

from mkctl.analysis.batch import csv_cell, write_rows
from mkctl.analysis.effect_files import (EffectFileError, load_effect_file, register_effect_file,
                                         unregister_effect_file, write_suggestion)
from mkctl.io.report import Section, markdown_text, visible, write_index

ROOT = Path(__file__).resolve().parents[1]

#: The payload of issue 30: it creates PWNED in the working folder if the text is ever run as code.
PAYLOAD = 'x""";__import__("os").system("touch PWNED");"""y'
#: Texts that are legal in a file name (no "/" and no NUL).
HOSTILE = [
    PAYLOAD,
    "it's \"quoted\" ''' '",
    "line\nbreak\r\nand\ttab",
    "</script><script>alert(1)</script>",
    "a & b &amp; <c> ]]> <!-- x",
    "100 % %s %n %.6g %%",
    "back\\slash\\ \\x41 \\",
    "ünïcødé µ² 中文 \u2028 end",
    "ctrl\x01\x07\x1b[31m\x7f",
    "trailing quote\"",
    "\udcff undecodable",
    "[link](javascript:alert(1)) ![i](x.png) *em* `code` # h",
    "=HYPERLINK(\"http://x\")",
]
#: The same without the characters XML 1.0 cannot carry (refused, tested apart): effect descriptions and units.
XML_HOSTILE = [t for t in HOSTILE if "\x01" not in t and "\udcff" not in t]

FOUND = {"explained": 0.99, "explained_holdout": 0.98, "terms": [
    {"term": "Ldot * |Ldot|", "coefficient": 2000.0, "stderr": 10.0, "unit": "N s^2/m^2", "matches": None}]}


def _ids(texts):
    return [ascii(t)[:24] for t in texts]


# --- generated Python: the suggested effect file --------------------------------------------------------------

@pytest.mark.parametrize("source", HOSTILE, ids=_ids(HOSTILE))
def test_the_suggested_effect_file_keeps_a_hostile_record_name_as_text(tmp_path, source):
    path = write_suggestion(tmp_path / "mine.py", FOUND, source=source + ".csv")
    text = path.read_text(encoding="utf-8")
    module = ast.parse(text)  # valid Python
    docstring = ast.get_docstring(module, clean=False)
    assert f" for {source}.csv." in docstring  # the name, intact, inside the docstring
    assert [type(node).__name__ for node in module.body] == ["Expr", "FunctionDef", "Assign"]
    # run it as `--effects mine.py` would, in a fresh process: the payload must not run
    done = subprocess.run([sys.executable, "-c", "import runpy, sys; runpy.run_path(sys.argv[1])", str(path)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "PWNED").exists()
    (effect,) = load_effect_file(path)
    assert source in effect.description or ascii(source) != source  # the description is a JSON literal


def test_diagnose_suggest_with_the_issue_s_record_name_runs_nothing(tmp_path):
    """The issue's reproduction, end to end: the record named with the payload, `diagnose --suggest`, then the
    suggested file loaded; and the JSON report carries the name as text."""
    record = tmp_path / f"{PAYLOAD}.csv"
    shutil.copy(ROOT / "docs" / "examples" / "knee_drag.csv", record)
    done = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", record.name, "--suggest", "mine.py",
                           "--json", "report.json", "--quiet"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    compile((tmp_path / "mine.py").read_text(), "mine.py", "exec")
    done = subprocess.run([sys.executable, "-c", "import runpy; runpy.run_path('mine.py')"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "PWNED").exists()
    report = json.loads((tmp_path / "report.json").read_text())

    def texts(value):
        if isinstance(value, dict):
            return [t for v in value.values() for t in texts(v)]
        if isinstance(value, list):
            return [t for v in value for t in texts(v)]
        return [value] if isinstance(value, str) else []

    assert any(PAYLOAD in text for text in texts(report))


# --- user effects: names are identifiers, texts without what XML cannot carry ----------------------------------

EFFECT = '''
def hostile(L, Ldot, P, p, xp):
    return p.c_h * Ldot


EFFECTS = [{{"name": {name!r}, "description": {description!r},
            "parameters": [{{"name": "c_h", "unit": {unit!r}, "off": 0.0, "lower": 0.0, "upper": 1e5,
                            "typical": 20.0}}],
            "term": hostile}}]
'''


@contextlib.contextmanager
def registered(tmp_path, description="drag", unit="N s/m", name="hostile_effect"):
    path = tmp_path / "hostile_effect.py"
    path.write_text(EFFECT.format(name=name, description=description, unit=unit), encoding="utf-8")
    register_effect_file(path)
    try:
        yield path
    finally:
        with contextlib.suppress(EffectFileError):
            unregister_effect_file(path)


@pytest.mark.parametrize("text", ["ctrl\x01", "esc\x1b[31m", "\udcff", "nul\x00"], ids=_ids(["a", "b", "c", "d"]))
def test_an_effect_text_xml_cannot_carry_is_refused_in_one_line(tmp_path, text):
    for fields in ({"description": text}, {"unit": text}):
        path = tmp_path / "e.py"
        path.write_text(EFFECT.format(**{"name": "hostile_effect", "description": "d", "unit": "N", **fields}),
                        encoding="utf-8", errors="surrogatepass")
        with pytest.raises(EffectFileError, match="cannot carry") as error:
            load_effect_file(path)
        assert "\n" not in str(error.value)


@pytest.mark.parametrize("name", ["é_drag", "drag\u0660", "x;y", "a b"])
def test_an_effect_or_parameter_name_must_be_an_ascii_identifier(tmp_path, name):
    path = tmp_path / "e.py"
    path.write_text(EFFECT.format(name=name, description="d", unit="N"), encoding="utf-8")
    with pytest.raises(EffectFileError, match="identifier"):
        load_effect_file(path)
    path.write_text(EFFECT.format(name="ok", description="d", unit="N").replace('"c_h"', repr(name)),
                    encoding="utf-8")
    with pytest.raises(EffectFileError, match="identifier"):
        load_effect_file(path)


# --- modelDescription.xml of both FMU kinds ---------------------------------------------------------------------

def _description_of(xml: bytes, variable: str) -> str:
    root = ET.fromstring(xml)
    (node,) = [v for v in root.iter() if v.get("name") == variable and v.get("valueReference") is not None]
    return node.get("description")


@pytest.mark.parametrize("description", XML_HOSTILE, ids=_ids(XML_HOSTILE))
def test_native_fmi2_and_fmi3_model_descriptions_keep_a_hostile_description_intact(tmp_path, description):
    from mkctl.native import fmi3
    from mkctl.native import fmu as native

    with registered(tmp_path, description=description):
        for model in native.MODEL_NAMES:
            interface = native.slave_interface(model)
            fmi2_xml = native.model_description(interface, "{guid}", ["a.c"], 0)
            fmi3_xml = fmi3.model_description(interface, "{token}", 0)
            for xml in (fmi2_xml, fmi3_xml):
                assert description in _description_of(xml, "c_h")
                assert _description_of(xml, "c_h").count(description) == 1


@pytest.mark.parametrize("description", XML_HOSTILE, ids=_ids(XML_HOSTILE))
def test_the_pythonfmu_model_description_keeps_a_hostile_description_intact(description):
    from mkctl.fmu.build import _complete_model_description

    root = ET.Element("fmiModelDescription", fmiVersion="2.0", modelName="m")
    ET.SubElement(root, "CoSimulation", modelIdentifier="m")
    variables = ET.SubElement(root, "ModelVariables")
    node = ET.SubElement(variables, "ScalarVariable", name="c_h", valueReference="0", description=description,
                         causality="parameter", variability="tunable")
    ET.SubElement(node, "Real", start="0.0")
    ET.SubElement(root, "ModelStructure")
    xml = _complete_model_description(ET.tostring(root, "UTF-8"), {"c_h": "N s/m"})
    assert _description_of(xml, "c_h") == description


def test_xml_refuses_what_it_cannot_carry_in_one_line():
    from mkctl.errors import MkctlError
    from mkctl.fmi.xml import xml_bytes

    root = ET.Element("a", description="bell\x07")
    with pytest.raises(MkctlError, match="cannot carry"):
        xml_bytes(root)


# --- generated C: string literals of the native FMUs ------------------------------------------------------------

def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


@pytest.mark.parametrize("unit", XML_HOSTILE, ids=_ids(XML_HOSTILE))
def test_model_variables_c_compiles_with_a_hostile_unit_and_keeps_it(tmp_path, unit):
    """The unit of a user effect's parameter is a C string of the native FMUs (and sits in a printf format of
    its range check, '%' included): the generated sources compile, and the unit comes back byte for byte."""
    from mkctl.native import fmu as native

    compiler = _compiler()
    require_or_skip(compiler is not None, "no C compiler (CC, cc, gcc, clang)")
    with registered(tmp_path, unit=unit):
        interface = native.slave_interface("McKibbenKnee")
        (tmp_path / "model_variables.h").write_text(native.variables_header(interface, "{guid}"))
        (tmp_path / "model_variables.c").write_text(native.variables_source(interface))
        (variable,) = [v for v in interface.variables if v.name == "c_h"]
        format_ = native._value_format(native.outside_domain_message("c_h", "\001", 0.0, 1e5, unit))
    done = subprocess.run([*compiler, "-std=c99", "-fsyntax-only", "-Wall", "-Werror=format", f"-I{tmp_path}",
                           f"-I{native.C_DIR}", f"-I{native.fmi2_headers()}", str(tmp_path / "model_variables.c")],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    assert native._c_string(variable.unit) in (tmp_path / "model_variables.c").read_text()
    _assert_c_strings_round_trip(tmp_path, compiler, [variable.unit, format_])
    assert format_.replace("%%", "").count("%") == 1  # one conversion: the value


def _assert_c_strings_round_trip(tmp_path, compiler, texts):
    from mkctl.native import fmu as native

    program = tmp_path / "strings.c"
    program.write_text("#include <stdio.h>\nstatic const char *texts[] = {\n"
                       + "".join(f"    {native._c_string(t)},\n" for t in texts)
                       + "};\nint main(void) {\n    for (unsigned k = 0; k < sizeof texts / sizeof *texts; k++) {\n"
                       "        fputs(texts[k], stdout); fputc(0, stdout);\n    }\n    return 0;\n}\n")
    binary = tmp_path / "strings"
    done = subprocess.run([*compiler, "-std=c99", "-Wall", "-Werror", "-o", str(binary), str(program)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    printed = subprocess.run([str(binary)], capture_output=True, check=True).stdout.split(b"\0")[:-1]
    assert printed == [t.encode("utf-8", "backslashreplace") for t in texts]


def test_every_hostile_text_is_a_c_string_literal_byte_for_byte(tmp_path):
    compiler = _compiler()
    require_or_skip(compiler is not None, "no C compiler (CC, cc, gcc, clang)")
    _assert_c_strings_round_trip(tmp_path, compiler, [t.replace("\x00", "") for t in HOSTILE] + ["??=??/"])


# --- index pages: HTML and Markdown -----------------------------------------------------------------------------

class _Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags, self.text, self.attributes = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attributes += [value for _, value in attrs]

    def handle_data(self, data):
        self.text.append(data)


def _index(tmp_path, text):
    out = tmp_path / "out"
    out.mkdir()
    name = text.replace("/", "_").replace("\x00", "")
    figure, table = out / f"{name}.png", out / f"{name}.csv"
    figure.write_bytes(b"\x89PNG\r\n")
    table.write_text("t\n0\n")
    section = Section(f"record {text}", summary=f"summary of {text}\n``` not the end")
    section.add(figure, f"figure {text}", f"what {text} shows")
    section.add(table, f"table {text}", f"the numbers of {text}")
    return out, write_index(out, f"run {text}", f"intro {text}", [section]), (figure, table)


@pytest.mark.parametrize("text", HOSTILE, ids=_ids(HOSTILE))
def test_the_html_index_has_no_tag_but_its_own_and_the_text_intact(tmp_path, text):
    out, (_, html_path), files = _index(tmp_path, text)
    page = _Page()
    page.feed(html_path.read_text(encoding="utf-8"))
    assert set(page.tags) <= {"html", "head", "meta", "title", "body", "h1", "h2", "h3", "p", "pre", "img", "a"}
    assert page.tags.count("img") == 1 and page.tags.count("a") == 1
    shown = "".join(page.text)
    for words in (f"run {text}", f"record {text}", f"figure {text}", f"what {text} shows", f"table {text}"):
        assert visible(words) in shown
    links = [unquote(v, errors="surrogateescape") for v in page.attributes if v.endswith((".png", ".csv"))]
    assert links == [f.name for f in files]


_LIVE_MARKDOWN = re.compile(r"[\\`*_{}\[\]<>()#!|~&$]")


@pytest.mark.parametrize("text", HOSTILE, ids=_ids(HOSTILE))
def test_the_markdown_index_has_no_live_markup_and_the_text_intact(tmp_path, text):
    out, (md_path, _), files = _index(tmp_path, text)
    md = md_path.read_text(encoding="utf-8")
    escaped = markdown_text(text)
    assert _LIVE_MARKDOWN.search(re.sub(r"\\.", "", escaped)) is None  # every markup character escaped
    assert re.sub(r"\\(.)", r"\1", escaped) == visible(" ".join(text.splitlines()))  # and nothing else changed
    assert f"# {markdown_text('run ' + text)}\n" in md
    assert f"### {markdown_text('figure ' + text)}\n\n{markdown_text(f'what {text} shows')}\n" in md
    fence = re.search(r"^(`{3,})text$", md, re.M).group(1)
    outside = re.sub(rf"^{fence}text\n.*?\n{fence}$", "", md, flags=re.S | re.M)  # the code block is inert
    # an unescaped "](" (escapes skipped pairwise): the page's own links only
    links = [m.group(1) for m in re.finditer(r"\\.|\]\(([^)\s]*)\)", outside) if m.group(1) is not None]
    assert [unquote(link, errors="surrogateescape") for link in links] == [f.name for f in files]
    body = md.split(fence + "text\n", 1)[1].split("\n" + fence + "\n", 1)[0]
    assert body == visible(f"summary of {text}\n``` not the end", keep="\n")


# --- CSV and JSON -----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("text", HOSTILE, ids=_ids(HOSTILE))
def test_a_csv_summary_reads_back_with_the_text_intact_and_no_formula(tmp_path, text):
    path = write_rows(tmp_path / "summary.csv", [{"file": text, "status": "ok", "rmse": -1.5},
                                                 {"file": "-" + text, "status": None, "rmse": 2.0}])
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    expected = [csv_cell(t).encode("utf-8", "backslashreplace").decode("utf-8") for t in (text, "-" + text)]
    assert [row["file"] for row in rows] == expected
    assert [row["rmse"] for row in rows] == ["-1.5", "2.0"]  # numbers stay numbers
    assert not any(row["file"].startswith(("=", "+", "-", "@")) for row in rows)


# --- figures: a record's name in a title ----------------------------------------------------------------------

@pytest.mark.parametrize("text", [*HOSTILE, "$x^{$ \\frac{1}{0} $_$", "a $\\alpha$ b"],
                         ids=_ids([*HOSTILE, "$x^{$", "alpha"]))
def test_a_figure_titled_with_a_hostile_record_name_saves_without_a_warning(tmp_path, text):
    """compare and diagnose put the record's name in their figures' titles: a tab or a control character has no
    glyph (a warning), and '$...$' that is not valid mathtext raised when the PNG was drawn."""
    import warnings

    from mkctl.io.plotting import new_figure, save_png

    fig, ax = new_figure()
    ax.plot([0, 1], [0, 1], label=f"measured ({text}.csv)")
    ax.set_title(f"{text}: baseline vs measurement")
    ax.legend()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        path = save_png(fig, tmp_path / "figure.png")
    assert path.read_bytes().startswith(b"\x89PNG")
    if "alpha" in text:  # valid mathtext of a name stays mathtext
        assert ax.title.get_parse_math()


def test_the_batch_figure_names_hostile_records_without_a_warning(tmp_path):
    """The batch's parameter figure writes each record's name under its axis (a fixed list of tick labels)."""
    import warnings

    from mkctl.analysis.batch import TICK_LABEL_CHARACTERS, plot_parameters, tick_label

    names = [*HOSTILE, "$x^{$ \\frac{1}{0} $_$", "中文" * 30]
    rows = [{"file": f"/data/{name.replace('/', '_')}.csv", "status": "ok", "c": 40.0 + k, "c_se": 0.5}
            for k, name in enumerate(names)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot_parameters(rows, ["c"], tmp_path / "parameters.png")
    labels = [tick_label(f"{name}.csv") for name in names]
    assert all(len(label.replace("\\$", "$")) <= TICK_LABEL_CHARACTERS and "\n" not in label for label in labels)
