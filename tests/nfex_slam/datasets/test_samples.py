"""nfex_slam.datasets.samples: frames of the data folder's sequences, listed by id."""
from __future__ import annotations

from pathlib import Path

from nfex_slam.datasets.samples import samples


def test_samples_spread_over_each_sequence(data_dir: Path) -> None:
    found = samples(data_dir, per_sequence=3)
    kitti = [s for s in found if s.dataset == "kitti" and s.sequence == "01"]
    if not kitti:
        import pytest

        pytest.skip("KITTI 01 is not in the data folder")
    assert [s.index for s in kitti] == [0, 25, 50] and all(s.path.is_file() for s in kitti)
    assert kitti[0].context == {"agent": "car", "scene": "outdoor"} and kitti[0].id == "kitti-01-0"
    assert len({s.id for s in found}) == len(found)


def test_an_empty_or_odd_folder_gives_nothing(tmp_path: Path) -> None:
    (tmp_path / "kitti" / "sequences" / "07").mkdir(parents=True)  # no images, no times.txt
    (tmp_path / "euroc" / "broken").mkdir(parents=True)
    assert samples(tmp_path) == []
