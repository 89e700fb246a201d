"""Benchmark tasks, executors, crash isolation, timeouts and the result cache (scripted pipeline)."""

import json

import numpy as np
import pytest
from benchmark_fake_pipeline import FRAME_RATE_HZ, FakeParams, write_tum_folder

from viewer_slam.benchmark.cache import ResultCache, sequence_fingerprint
from viewer_slam.benchmark.executors import LocalExecutor, run_tasks
from viewer_slam.benchmark.plan import plan_tasks
from viewer_slam.benchmark.runner import BenchmarkTask, execute_task
from viewer_slam.benchmark.suite import deliver_files, run_benchmark
from viewer_slam.record.command import record
from viewer_slam.runs.run_report import write_report

pytestmark = pytest.mark.usefixtures("fake_pipeline")


def task(folder, name="tiny", **parameters):
    return BenchmarkTask(name=name, sequence=folder, pipeline="fake", params=FakeParams(**parameters))


def test_task_scores_the_run_against_groundtruth(folder):
    result = execute_task(task(folder, lost_from=10, lost_until=20))
    assert result.ok and result.error is None
    report = result.report
    assert result.frames == 30 and report["frames_with_pose"] == 20
    assert report["ate"]["rmse"] < 1e-5  # a constant offset is removed by the alignment
    # Lost from the last pose (frame 9) to the next (frame 20): 11 of 29 frame periods.
    assert report["coverage"]["ratio"] == pytest.approx(1 - 11 / 29, abs=1e-5)  # stamps have 6 decimals
    [[start, end]] = report["coverage"]["lost_intervals"]
    assert (start - 1000.0, end - 1000.0) == pytest.approx((9 / FRAME_RATE_HZ, 20 / FRAME_RATE_HZ), abs=1e-6)
    assert report["tracking_lost"][0]["reason"] == "scripted loss"
    assert result.time_span == pytest.approx((1000.0, 1000.0 + 29 / FRAME_RATE_HZ))


def test_frame_limit_does_not_count_unprocessed_time_as_lost(folder):
    result = execute_task(BenchmarkTask(name="tiny", sequence=folder, pipeline="fake", max_frames=12))
    assert result.frames == 12 and result.report["coverage"]["ratio"] == 1.0


def test_failures_are_reported_and_the_other_tasks_finish(folder, tmp_path):
    corrupt = tmp_path / "corrupt"
    corrupt.mkdir()
    (corrupt / "rgb.txt").write_text("1.0 rgb/1.png\n")
    tasks = [
        task(folder, name="a"),
        task(folder, name="raises", fail="raise"),
        task(folder, name="exits", fail="exit"),
        task(folder, name="calls-sys-exit", fail="sys.exit"),
        BenchmarkTask(name="hangs", sequence=folder, pipeline="fake", params=FakeParams(fail="hang"), timeout_s=2),
        BenchmarkTask(name="corrupt", sequence=corrupt, pipeline="fake"),
        task(folder, name="b"),
    ]
    results = run_tasks(tasks, LocalExecutor(jobs=2))
    assert [result.sequence for result in results] == [
        "a",
        "raises",
        "exits",
        "calls-sys-exit",
        "hangs",
        "corrupt",
        "b",
    ]
    assert [result.status for result in results] == ["ok", "failed", "failed", "failed", "failed", "failed", "ok"]
    assert results[1].error == "RuntimeError: scripted failure"
    assert results[2].error == "worker process died"
    assert results[3].error == "SystemExit: the task called sys.exit(5)"
    assert results[4].error == "TaskTimeout: timed out after 2 s"
    assert results[5].error.startswith("InputError: ") and "depth.txt" in results[5].error
    assert results[0].report == results[6].report | {"timing": results[0].report["timing"]}


def test_rerun_is_served_from_the_cache_until_inputs_change(folder, tmp_path):
    cache = ResultCache(tmp_path / "results")
    tasks = [task(folder), task(folder, fail="raise")]
    first = run_benchmark(tasks, LocalExecutor(jobs=1), cache, progress=False).results
    assert [result.cached for result in first] == [False, False]
    second = run_benchmark(tasks, LocalExecutor(jobs=1), cache, progress=False).results
    assert [result.cached for result in second] == [True, False]  # failures are retried
    assert second[0].report == first[0].report and second[0].time_span == first[0].time_span
    changed = [task(folder, offset_m=0.02)]
    assert not run_benchmark(changed, LocalExecutor(jobs=1), cache, progress=False).results[0].cached
    (folder / "groundtruth.txt").write_text((folder / "groundtruth.txt").read_text() + "\n")
    assert not ResultCache(tmp_path / "results").load(tasks[0])  # the next run sees the change


def test_fingerprint_follows_image_sizes_and_listings(folder):
    before = sequence_fingerprint(folder)
    assert sequence_fingerprint(folder) == before
    image = sorted((folder / "rgb").iterdir())[3]
    image.write_bytes(image.read_bytes() + b"\0")
    assert sequence_fingerprint(folder) != before


def test_cached_result_is_not_used_when_its_recording_is_missing(folder, tmp_path):
    cache = ResultCache(tmp_path / "results")
    plain = task(folder)
    cache.store(plain, execute_task(plain))
    recorded = BenchmarkTask(name="tiny", sequence=folder, pipeline="fake", recording=tmp_path / "x.rrd")
    assert cache.key(recorded) == cache.key(plain)
    assert cache.load(plain) is not None and cache.load(recorded) is None


def test_results_do_not_depend_on_the_number_of_workers(folder):
    tasks = [task(folder, name=str(k), wobble_m=0.01 * k, lost_from=5 * k) for k in range(1, 5)]
    serial = run_tasks(tasks, LocalExecutor(jobs=1))
    parallel = run_tasks(tasks, LocalExecutor(jobs=2))
    for one, other in zip(serial, parallel):
        assert {k: v for k, v in one.report.items() if k != "timing"} == {
            k: v for k, v in other.report.items() if k != "timing"
        }
    assert np.all(np.diff([result.report["ate"]["rmse"] for result in serial]) > 0)


def test_recorded_task_returns_its_recording_and_scores_the_same(folder, tmp_path):
    """The worker sends the recording, its report and trajectory back as bytes (it writes nothing
    where the driver keeps them); the driver writes them there."""
    recording = tmp_path / "rec" / "tiny.fake.rrd"
    recording_task = BenchmarkTask(
        name="tiny", sequence=folder, pipeline="fake", params=FakeParams(lost_from=8), recording=recording
    )
    recorded = execute_task(recording_task)
    plain = execute_task(task(folder, lost_from=8))
    assert recorded.ok, recorded.error
    assert sorted(recorded.files) == ["tiny.fake.fake.txt", "tiny.fake.json", "tiny.fake.rrd"]
    assert not recording.parent.exists()
    assert "files" not in recorded.to_json()  # never cached
    assert recorded.files["tiny.fake.fake.txt"].decode() == recorded.trajectory
    delivered = deliver_files(recording_task, recorded)
    assert delivered.ok and not delivered.files
    assert recording.stat().st_size > 0 and json.loads(recording.with_suffix(".json").read_text())["pipelines"]["fake"]
    assert {k: v for k, v in recorded.report.items() if k != "timing"} == {
        k: v for k, v in plain.report.items() if k != "timing"
    }
    assert (recorded.frames, recorded.time_span) == (plain.frames, plain.time_span)


def test_an_estimate_task_is_cached_under_its_file_s_bytes(folder, tmp_path):
    """An estimate replayed is served from the cache until the file's content changes."""
    estimate = tmp_path / "estimate.txt"
    estimate.write_text((folder / "groundtruth.txt").read_text())
    cache = ResultCache(tmp_path / "results")
    replay = BenchmarkTask(name="tiny", sequence=folder, pipeline="mine", estimate=estimate, estimate_format="tum")
    first = run_benchmark([replay], LocalExecutor(jobs=1), cache, progress=False).results[0]
    assert first.ok and not first.cached and first.report["source"] == "estimate"
    assert first.report["ate"]["rmse"] == pytest.approx(0.0, abs=1e-6)  # the groundtruth itself
    assert run_benchmark([replay], LocalExecutor(jobs=1), cache, progress=False).results[0].cached
    estimate.write_text(estimate.read_text() + "# the same poses, other bytes\n")
    assert cache.load(replay) is None


def test_record_and_a_benchmark_task_score_the_same_run_alike(folder, tmp_path):
    """One run service: `record` with the parameters as text and a task with them as a validated
    object give the same report block (timing aside) and the same trajectory file."""
    recorded = record(
        str(folder),
        pipeline="fake",
        out=tmp_path / "run.rrd",
        max_frames=20,
        params=["lost_from=8", "lost_until=14"],
        quiet=True,
    )
    task_result = execute_task(
        BenchmarkTask(
            name="tiny", sequence=folder, pipeline="fake", max_frames=20, params=FakeParams(lost_from=8, lost_until=14)
        )
    )
    assert task_result.ok, task_result.error
    write_report(tmp_path / "task.json", {"pipelines": {"fake": task_result.report}})
    blocks = [
        json.loads(path.read_text())["pipelines"]["fake"] for path in (recorded.report_path, tmp_path / "task.json")
    ]
    assert [{k: v for k, v in block.items() if k != "timing"} for block in blocks] == [
        {k: v for k, v in blocks[0].items() if k != "timing"}
    ] * 2
    assert blocks[0]["tracking_lost"] and blocks[0]["ate"]["n"] == 14
    assert recorded.trajectories["fake"].read_text() == task_result.trajectory


def test_a_machine_without_the_planned_folder_renders_the_scenario_in_its_own_cache(tmp_path, monkeypatch):
    """A scenario renders to the same bytes on every machine, so a node whose cache lacks the
    driver's folder renders it into its own and runs the same run; the result names the
    driver's folder. A folder given by path has no other way to be found."""
    [planned] = plan_tasks(["sitting_static"], ["rtabmap"], scenario_frames=10, resolution=(160, 120))
    here = execute_task(planned)
    planned.sequence.rename(tmp_path / "not-on-this-machine")
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "node-cache"))
    there = execute_task(planned)
    assert here.ok and there.ok, there.error
    assert (tmp_path / "node-cache" / "synth" / planned.sequence.name).is_dir()
    assert {k: v for k, v in there.report.items() if k != "timing"} == {
        k: v for k, v in here.report.items() if k != "timing"
    }
    assert there.trajectory == here.trajectory and there.sequence_block == here.sequence_block

    folder = write_tum_folder(tmp_path / "given", frames=5)
    [by_path] = plan_tasks([str(folder)], ["fake"])
    folder.rename(tmp_path / "gone")
    failed = execute_task(by_path)
    assert by_path.source is None and not failed.ok and str(folder) in failed.error
