"""The nFEX HTTP service: a thin FastAPI layer over nfex_core (the advisor and the knowledge graph)."""
