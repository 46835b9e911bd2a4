"""The nFEX rule language: grammar ``rules/nfex.lark``, parser, name checks, compiler to triples (docs/dsl.md)."""
from __future__ import annotations

from ...kg.identity import program_iri
from .check import check, problems
from .compiler import compile_program, decompile
from .parser import Atom, Pos, Program, Statement, parse, parse_file, render

__all__ = ["Atom", "Pos", "Program", "Statement", "check", "compile_program", "decompile", "parse", "parse_file", "problems", "program_iri", "render"]
