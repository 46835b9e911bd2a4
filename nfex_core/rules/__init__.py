"""Symbolic reasoning: SPARQL pruning rules, the DSL, and the compiled rule engine."""
