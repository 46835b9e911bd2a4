from __future__ import annotations

from pathlib import Path

from nfex_core.sweeps import table


def _row(x: str, ate: float | None, window: int = 0, failed: int = 0, cell: str = "") -> dict[str, object]:
    return {"dataset": "kitti", "sequence": "00", "corruption": "none", "severity": 0.0, "seed": 0,
            "window_start": window, "extractor": x, "ate_rmse": ate, "failed": failed, "cell": cell or f"{x}{ate}{window}",
            "params": "{}"}


def test_best_labels_per_window_and_extractor_never_a_failure() -> None:
    rows = [_row("ORB", 0.5), _row("ORB", 0.3), _row("SIFT", 0.2), _row("SIFT", 0.01, failed=1),
            _row("ORB", 0.9, window=10), _row("SIFT", None, window=10, failed=1)]
    table.label(rows)
    assert [r["best_overall"] for r in rows] == [0, 0, 1, 0, 1, 0]
    assert [r["best_for_extractor"] for r in rows] == [0, 1, 1, 0, 1, 0]


def test_round_trip_keeps_columns_and_empty_failures(tmp_path: Path) -> None:
    rows = table.label([_row("ORB", 0.25), {**_row("SIFT", None, failed=1), "m.density": 0.5}])
    path = tmp_path / "t.csv"
    table.write(path, rows)
    back = table.read(path)
    assert list(back[0])[: len(table.BASE_COLUMNS)] == table.BASE_COLUMNS
    assert "m.density" in back[0] and list(back[0])[-1] == "cell"
    assert back[0]["ate_rmse"] == "0.25" and back[1]["ate_rmse"] == ""
    assert back[0]["best_overall"] == "1" and back[1]["best_overall"] == "0"


def test_the_pair_table_of_a_compressed_table_sits_beside_it(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Shipped tables are gzipped (data/sweeps/dense-*.csv.gz); their pair tables keep the plain table's name."""
    import gzip
    from pathlib import Path

    from nfex_core.sweeps.table import pairs_path, read

    assert pairs_path(Path("d/kitti00.csv")) == pairs_path(Path("d/kitti00.csv.gz")) == Path("d/kitti00-pairs.csv.gz")
    plain = tmp_path / "t.csv"
    plain.write_text("a,b\n1,2\n")
    (tmp_path / "t.csv.gz").write_bytes(gzip.compress(plain.read_bytes()))
    assert read(tmp_path / "t.csv.gz") == read(plain) == [{"a": "1", "b": "2"}]
