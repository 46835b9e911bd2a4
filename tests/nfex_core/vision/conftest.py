"""Fixtures for the vision tests: one seeded vocabulary per module, real frames from ../shared/data."""
from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.vocabulary.vocab import Vocabulary
from nfex_core.vision.registry import ExtractorRegistry

EUROC = "euroc/V1_01_easy_micro/mav0/cam0/data"
KITTI = "kitti/sequences/00/image_0"
HANDHELD = "handheld/checkerboard/images"


@pytest.fixture(scope="module")
def vocab(seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Vocabulary]:
    """The seeded graph's vocabulary (read-only: tests that write use the ``kg`` fixture)."""
    dest = tmp_path_factory.mktemp("vision") / "store"
    shutil.copytree(seeded_template, dest, ignore=shutil.ignore_patterns("LOCK"))
    kg = KnowledgeGraph.open(str(dest))
    yield kg.vocabulary()
    kg.close()


@pytest.fixture(scope="module")
def registry(vocab: Vocabulary) -> ExtractorRegistry:
    return ExtractorRegistry.from_vocabulary(vocab)


def frames(data_dir: Path, folder: str, indices: list[int]) -> list[np.ndarray]:
    """Grey frames number ``indices`` (in sorted file order) of a dataset folder; skip when absent."""
    files = sorted(p for p in (data_dir / folder).iterdir() if p.suffix in (".png", ".jpg"))
    if not files:
        pytest.skip(f"no frames in {data_dir / folder}")
    out = [cv2.imread(str(files[i]), cv2.IMREAD_GRAYSCALE) for i in indices]
    assert all(f is not None for f in out)
    return out


@pytest.fixture(scope="module")
def euroc_pair(data_dir: Path) -> list[np.ndarray]:
    return frames(data_dir, EUROC, [40, 41])


@pytest.fixture(scope="module")
def kitti_pair(data_dir: Path) -> list[np.ndarray]:
    return frames(data_dir, KITTI, [20, 21])
