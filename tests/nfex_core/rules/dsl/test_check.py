"""Names are checked against the graph's vocabulary: unknown ones are rejected with the known names."""
from __future__ import annotations

import pytest

from nfex_core.errors import ParameterError, UnknownName
from nfex_core.kg.vocabulary.vocab import Vocabulary
from nfex_core.rules.dsl.check import check, problems
from nfex_core.rules.dsl.parser import parse


def _only(text: str, vocab: Vocabulary) -> UnknownName | ParameterError:
    with pytest.raises((UnknownName, ParameterError)) as e:
        check(parse("program p\n" + text, source="p.nfex"), vocab)
    return e.value


def test_a_valid_program_passes(vocab: Vocabulary) -> None:
    p = parse("program p\nprune SIFT when agent is car\nadjust ORB.nfeatures by 2 when light is dark\nweight motion 1.5\n"
              "prefer AKAZE by 0.1 when texture is one of (low, medium)\nrequire ORB.fastThreshold <= 10 when light is dark")
    assert check(p, vocab) is p


@pytest.mark.parametrize(
    ("text", "kind", "name", "column", "known"),
    [
        ("prune SURF when agent is car", "extractor", "SURF", 7, ["AKAZE", "BRISK", "ORB", "SIFT"]),
        ("adjust ORB.nfeaturez by 2", "parameter", "ORB.nfeaturez", 12, ["ORB.nfeatures", "ORB.fastThreshold"]),
        ("weight sharpness 2.0", "metric", "sharpness", 8, ["texturedness", "repeatability"]),
        ("prune ORB when weather is rain", "condition dimension", "weather", 16, ["agent", "light", "texture"]),
        ("prune ORB when agent is robot", "value of agent", "robot", 25, ["car", "drone", "human"]),
        ("prune ORB when texture is one of (low, none)", "value of texture", "none", 40, ["high", "low", "medium"]),
    ],
)
def test_unknown_names_with_line_column_and_known_names(
    vocab: Vocabulary, text: str, kind: str, name: str, column: int, known: list[str]
) -> None:
    e = _only(text, vocab)
    assert isinstance(e, UnknownName)
    assert (e.kind, e.name) == (kind, name)
    assert (e.extra["line"], e.extra["column"]) == (2, column)
    assert set(known) <= set(e.known)
    assert e.detail.startswith(f"p.nfex:2:{column}: unknown {kind} '{name}'; known: ")


def test_known_names_come_from_the_vocabulary(vocab: Vocabulary) -> None:
    e = _only("prune SURF", vocab)
    assert e.known == sorted(vocab.extractors)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("adjust ORB.WTA_K by 2", "not a tunable number"),
        ("adjust ORB.nfeatures by 0", "greater than 0"),
        ("weight motion -1", "0 or more"),
        ("require ORB.fastThreshold <= 1000", "outside its range"),
        ("require ORB.nfeatures <= 10.5", "not an integer"),
        ("require SIFT.enable_precise_upscale < true", "with '='"),
    ],
)
def test_numbers_are_checked_against_the_graph(vocab: Vocabulary, text: str, says: str) -> None:
    e = _only(text, vocab)
    assert isinstance(e, ParameterError)
    assert says in e.detail and e.extra["line"] == 2


def test_every_problem_is_reported(vocab: Vocabulary) -> None:
    p = parse("program p\nprune SURF\nweight sharpness 1\nprune ORB when agent is robot")
    found = problems(p, vocab)
    assert [(e.extra["line"], e.extra["column"]) for e in found] == [(2, 7), (3, 8), (4, 25)]
    with pytest.raises(UnknownName, match=r"and 2 more problems"):
        check(p, vocab)


def test_a_learned_extractor_is_named_like_any_other(vocab: Vocabulary) -> None:
    """XFeat (issue 15) is in the graph, so statements may name it and its parameters, checked like ORB's."""
    text = ('prune XFEAT when agent is drone because "no network on the drone\'s flight computer"\n'
            "adjust XFEAT.top_k by 0.5 when light is dark\nrequire XFEAT.input_scale <= 0.75 when agent is human")
    p = parse("program p\n" + text)
    assert check(p, vocab) is p
    e = _only("adjust XFEAT.topk by 2", vocab)
    assert isinstance(e, UnknownName) and "XFEAT.top_k" in e.known
    e = _only("require XFEAT.input_scale <= 2", vocab)
    assert isinstance(e, ParameterError) and "outside its range" in e.detail
