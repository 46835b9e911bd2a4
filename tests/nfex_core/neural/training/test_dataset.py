from __future__ import annotations

from pathlib import Path

import numpy as np

from nfex_core.neural.selectornet import IMAGE_HW
from nfex_core.neural.training.dataset import Window, default_image_source


def window(corruption: str, severity: str = "0.7", dataset: str = "kitti", sequence: str = "00") -> Window:
    return Window(dataset, sequence, corruption, severity, "0", 10, 30, {}, {}, 1241 * 376)


def test_images_of_windows_follow_the_sweeps_corruption(data_dir: Path) -> None:
    source = default_image_source(data_dir)
    clean, dark = source(window("none")), source(window("dark"))
    assert clean is not None and dark is not None
    assert clean.shape == dark.shape == IMAGE_HW and clean.dtype == np.float32
    assert 0.0 <= dark.min() and clean.max() <= 1.0
    assert dark.mean() < 0.6 * clean.mean()  # the dark corruption, as the sweep measured it


def test_missing_sequence_gives_no_image(data_dir: Path) -> None:
    assert default_image_source(data_dir)(window("none", sequence="99")) is None


def test_a_scheduled_window_gets_its_segments_image(data_dir: Path) -> None:
    """A schedule window (the sweep's corruption "schedule") shows the corruption of the segment it starts in."""
    source = default_image_source(data_dir)
    w = window("schedule")
    w.schedule = "none:0-99,dark:100-199"
    early = source(w)
    w2 = window("schedule")
    w2.schedule, w2.start = "none:0-99,dark:100-199", 150
    late, plain = source(w2), source(Window("kitti", "00", "none", "0", "0", 150, 160, {}, {}, 1241 * 376))
    clean = source(window("none"))
    assert early is not None and late is not None and plain is not None and clean is not None
    np.testing.assert_array_equal(early, clean)  # frame 10 lies in the clean segment
    assert late.mean() < 0.6 * plain.mean()  # frame 150 lies in the dark one
