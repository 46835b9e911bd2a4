"""The grammar: every statement form, comments, line continuation, and syntax errors with line and column."""
from __future__ import annotations

import pytest

from nfex_core.errors import ParseError
from nfex_core.rules.dsl.parser import Atom, parse, render

PROGRAM = '''# a comment line
program demo   # trailing comment
prune SIFT when agent is car and motion is fast because "fails on KITTI"
adjust ORB.nfeatures by 1.6 when light is dark
weight texturedness 2.0
    when light is dark
prefer ORB by -0.25 when texture is one of (high, medium)
require ORB.fastThreshold <= 10 when light is not dark
require SIFT.enable_precise_upscale = true because "escapes: \\" \\\\ \\n"
'''


def test_every_statement_form() -> None:
    p = parse(PROGRAM)
    assert p.name == "demo"
    prune, adjust, weight, prefer, require, flag = p.statements
    assert (prune.kind, prune.extractor, prune.reason) == ("prune", "SIFT", "fails on KITTI")
    assert prune.when == (Atom("agent", ("car",)), Atom("motion", ("fast",)))
    assert (adjust.extractor, adjust.parameter, adjust.value) == ("ORB", "nfeatures", 1.6)
    assert (weight.metric, weight.value, weight.when) == ("texturedness", 2.0, (Atom("light", ("dark",)),))
    assert (prefer.extractor, prefer.value) == ("ORB", -0.25)
    assert prefer.when == (Atom("texture", ("high", "medium")),)  # sorted
    assert (require.comparator, require.value, require.when) == ("<=", 10, (Atom("light", ("dark",), negated=True),))
    assert flag.value is True and flag.reason == 'escapes: " \\ \n'


def test_positions_of_statements_and_names() -> None:
    p = parse(PROGRAM)
    adjust = p.statements[1]
    assert (adjust.pos.line, adjust.pos.column) == (4, 1)
    assert (adjust.at["parameter"].line, adjust.at["parameter"].column) == (4, 12)
    weight = p.statements[2]
    assert weight.when[0].at["dimension"].line == 6


def test_render_is_canonical_and_parses_back() -> None:
    p = parse(PROGRAM)
    text = render(p)
    assert text.startswith("program demo\n")
    assert "prefer ORB by -0.25 when texture is one of (high, medium)\n" in text
    assert parse(text) == p


def test_name_from_the_caller_when_there_is_no_header() -> None:
    assert parse("prune ORB", name="x").name == "x"
    with pytest.raises(ParseError, match="no name"):
        parse("prune ORB")


@pytest.mark.parametrize(
    ("text", "line", "column", "says"),
    [
        ("program p\nprune SIFT when agent car", 2, 23, "expected 'is'"),
        ("program p\n\nadjust ORB.nfeatures 1.6", 3, 22, "expected 'by'"),
        ('program p\nprune SIFT because "no end', 2, 20, "unterminated string"),
        ("program p\nweight texturedness two", 2, 21, "unexpected 'two'"),
        ("program p\nprune SIFT when light is dark and", 2, 34, "end of the program"),
        ("program p\nprune $IFT", 2, 7, "unexpected character '$'"),
        ("program p\nrequire ORB.nfeatures => 5", 2, 24, "expected a number, true or false"),
        ("program p\nprefer ORB 0.2", 2, 12, "expected 'by'"),
    ],
)
def test_syntax_errors_carry_line_and_column(text: str, line: int, column: int, says: str) -> None:
    with pytest.raises(ParseError) as e:
        parse(text, source="x.nfex")
    assert (e.value.line, e.value.column) == (line, column), e.value.detail
    assert says in e.value.detail
    assert e.value.detail.startswith(f"x.nfex:{line}:{column}: ")
