"""Shared fixtures: a seeded registry and the first KITTI frames."""
from __future__ import annotations

from pathlib import Path

import pytest
from nfex_slam.datasets import open_sequence
from nfex_slam.datasets.base import Sequence

from nfex_core.kg import KnowledgeGraph
from nfex_core.vision.registry import ExtractorRegistry


@pytest.fixture(scope="session")
def registry(seeded_template: Path) -> ExtractorRegistry:
    kg = KnowledgeGraph.open(str(seeded_template))
    try:
        return ExtractorRegistry.from_vocabulary(kg.vocabulary())
    finally:
        kg.close()


@pytest.fixture(scope="session")
def kitti01(data_dir: Path) -> Sequence:
    return open_sequence(data_dir / "kitti", "kitti", "01")


@pytest.fixture(scope="session")
def kitti00(data_dir: Path) -> Sequence:
    return open_sequence(data_dir / "kitti", "kitti", "00")
