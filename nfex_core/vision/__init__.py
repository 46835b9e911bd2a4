"""Vision core: extractors built from the graph, the quality metrics m1–m7, context estimation."""
