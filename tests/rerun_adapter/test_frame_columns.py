"""Rows held and sent as columns are the rows that logging them one by one records."""

import numpy as np
import rerun as rr
from rerun.chunk import RrdReader

from viewer_slam.geometry.se3 import make_pose
from viewer_slam.rerun_adapter.frame_columns import HeldRows
from viewer_slam.rerun_adapter.recorder import set_frame_time, transform

RNG = np.random.default_rng(7)
# Stamps whose nanoseconds a truncating conversion gets wrong by one (2/30 s is 66666666.67 ns: a
# synthetic scene's 30 Hz frames), TUM's stamps (whole multiples of 256 ns as doubles), and 0.
STAMPS = [0.0, 1 / 30, 2 / 30, 5 / 30, 0.7, 1305031229.528748, 1305031229.564425, 1305031229.5966, 1305031229.628753]


def rows_of(frame: int) -> list[tuple]:
    """The rows of one frame, as (kind, path, value): numbers, a pose, matches, clears at one entity in
    both orders, the same entity twice in a frame, and frames where an entity is only cleared."""
    rows: list[tuple] = [("scalar", "metrics/features", float(RNG.integers(0, 500)))]
    rows += [("scalar", "metrics/graph_error", float(RNG.random())) for _ in range(1 + frame % 2)]
    rows.append(("pose", "world/camera", make_pose(np.eye(3), RNG.normal(size=3))))
    segments = RNG.random((1 + frame % 4, 2, 2)).astype(np.float32) * 100
    if frame % 3 == 0:  # cleared, then drawn, at one time (a run that reports its state first)
        rows += [("clear", "matches", True), ("segments", "matches", segments)]
    elif frame % 3 == 1:  # drawn, then cleared, at one time
        rows += [("segments", "matches", segments), ("clear", "matches", False)]
    else:
        rows.append(("clear", "matches", True))
    rows.append(("segments" if frame % 4 else "clear", "matches/outliers", segments if frame % 4 else False))
    return rows


def log_row(stream: rr.RecordingStream, kind: str, path: str, value) -> None:
    archetype = {
        "scalar": lambda: rr.Scalars(value),
        "pose": lambda: transform(value),
        "segments": lambda: rr.LineStrips2D(value, radii=rr.Radius.ui_points(1.0)),
        "clear": lambda: rr.Clear(recursive=value),
    }[kind]()
    stream.log(path, archetype)


def hold_row(held: HeldRows, frame: int, stamp: float, kind: str, path: str, value) -> None:
    if kind == "scalar":
        held.scalar(path, frame, stamp, value)
    elif kind == "pose":
        held.transform(path, frame, stamp, value)
    elif kind == "segments":
        held.segments(path, frame, stamp, value, rr.Radius.ui_points(1.0))
    else:
        held.clear(path, frame, stamp, value)


def content(path) -> tuple[dict, dict]:
    """Per (entity, component): its (frame, time, value) in row order; and per entity and time with
    several rows, the components of each row in row order (what decides which row wins)."""
    values: dict = {}
    order: dict = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == "/__properties":  # the recording's start time
            continue
        batch = chunk.to_record_batch().to_pydict()
        ids = batch.pop("rerun.controls.RowId")
        frames, times = batch.pop("frame", [None] * len(ids)), batch.pop("time", [None] * len(ids))
        for row, (row_id, frame, time) in enumerate(zip(ids, frames, times)):
            present = {name: column[row] for name, column in batch.items() if column[row] is not None}
            for name, value in present.items():
                values.setdefault((chunk.entity_path, name), []).append((row_id, frame, time, value))
            order.setdefault((chunk.entity_path, frame, time), []).append((row_id, sorted(present)))
    return (
        {key: [row[1:] for row in sorted(rows, key=lambda row: row[0])] for key, rows in values.items()},
        {key: [row[1] for row in sorted(rows)] for key, rows in order.items() if len(rows) > 1},
    )


def recorded(tmp_path, name: str, write) -> tuple[dict, dict]:
    stream = rr.RecordingStream("viewslam-test")
    rr.set_log_time_enabled(False, recording=stream)  # as a recording file has it
    stream.save(tmp_path / f"{name}.rrd")
    write(stream)
    stream.flush()
    stream.disconnect()
    return content(tmp_path / f"{name}.rrd")


def test_held_rows_record_what_logging_each_row_records(tmp_path):
    frames = [(frame, stamp, rows_of(frame)) for frame, stamp in enumerate(STAMPS)]

    def logged(stream):
        for frame, stamp, rows in frames:
            set_frame_time(stream, frame, stamp)
            for row in rows:
                log_row(stream, *row)

    def held(stream):
        held = HeldRows(stream, flush_frames=4)
        for frame, stamp, rows in frames:
            held.next_frame()
            for row in rows:
                hold_row(held, frame, stamp, *row)
        held.flush()

    by_log, by_columns = recorded(tmp_path, "logged", logged), recorded(tmp_path, "held", held)
    assert set(by_columns[0]) == set(by_log[0]) and len(by_log[0]) == 10  # 4 entities, 10 components
    for key, rows in by_log[0].items():
        assert by_columns[0][key] == rows, key
    assert by_columns[1] == by_log[1]
    assert {order[0][0] for order in by_log[1].values()} >= {"Clear:is_recursive", "LineStrips2D:radii"}


def test_rows_wait_for_a_flush_every_few_frames_and_the_last_ones_for_the_end(tmp_path):
    sent: list[tuple[str, list[int]]] = []

    class Stream:
        def send_columns(self, path, indexes, columns):
            sent.append((path, indexes[0].as_arrow_array().to_pylist()))

    held = HeldRows(Stream(), flush_frames=3)  # type: ignore[arg-type]
    for frame in range(7):
        held.next_frame()
        held.scalar("a", frame, float(frame), 1.0)
        held.scalar("b", frame, float(frame), 2.0)
        if frame < 3:
            assert sent == []
    assert sent == [("a", [0, 1, 2]), ("b", [0, 1, 2]), ("a", [3, 4, 5]), ("b", [3, 4, 5])]
    held.flush()
    held.flush()  # nothing more held: nothing sent, never an empty chunk
    assert sent[4:] == [("a", [6]), ("b", [6])]
