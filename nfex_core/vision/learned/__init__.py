"""Learned extractors (issue 15): XFeat first; heavy imports (onnxruntime, torch) stay lazy."""
