"""benchmarks.situations: a full run renders and runs the seven scenarios (an hour); ``--redraw`` draws
the charts again from the table docs/benchmark.md holds, which is what is tested here."""

from benchmarks import situations
from benchmarks.figures import REPO


def test_the_documented_table_reads_back_as_chart_rows():
    rows = situations.documented_rows((REPO / "docs" / "benchmark.md").read_text())
    assert {row["pipeline"] for row in rows} == {"rgbdslam", "rtabmap"}
    assert len(rows) == 2 * len({row["sequence"] for row in rows}) >= 14
    assert all(row["coverage"] is None or 0 <= row["coverage"] <= 1 for row in rows)
    assert any(row["ate_rmse"] is not None for row in rows)


def test_redraw_draws_the_charts_from_the_table(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(situations, "IMAGES", tmp_path)
    assert situations.main(["--redraw"]) == 0
    drawn = sorted(path.name for path in tmp_path.iterdir())
    assert drawn and all(name.startswith("benchmark_") and name.endswith((".png", ".svg")) for name in drawn)
    assert {name.removesuffix(".svg") for name in drawn if name.endswith(".svg")} == {
        name.removesuffix(".png") for name in drawn if name.endswith(".png")
    }
    assert sorted(capsys.readouterr().out.split()) == [str(tmp_path / name) for name in drawn]
