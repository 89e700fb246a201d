"""`benchmark --executor ray --ray-address` on a real cluster: a head and a second node started with
`ray start` on 127.0.0.1, each its own processes, temporary folder and scratch space.

Every result, report and recording must come back to the driver's --out, equal the local pool's,
be served from the cache on a re-run, and a node lost in the middle of a task must leave failed
rows for its tasks while the others complete. The driver runs as a process of its own, as a
user's would. The scripted pipeline keeps the tasks small; each node leaves a marker file per
run it starts, so the test sees where tasks ran (and that a re-run runs nothing).
"""

import contextlib
import importlib.util
import json
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from benchmark_fake_pipeline import MODULE, write_tum_folder

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="Ray is not installed"),
]

ROOT = Path(__file__).parents[2]
RAY = Path(sys.executable).with_name("ray")
STARTED = "block forever"  # what `ray start --block` logs once its node is up
DRIVER = (
    "import sys; from viewer_slam.pipelines import base; base.PIPELINE_MODULES['fake'] = sys.argv[1]; "
    "from viewer_slam.cli import main; sys.exit(main(sys.argv[2:]))"
)
TRIALS = 4
# A lost node is declared dead after a few missed half-second health checks, not Ray's default 30 s or more.
HEALTH_CHECKS = {
    "RAY_health_check_initial_delay_ms": "0",
    "RAY_health_check_period_ms": "500",
    "RAY_health_check_timeout_ms": "500",
    "RAY_health_check_failure_threshold": "4",
}


@dataclass
class Node:
    process: subprocess.Popen
    folder: Path

    @property
    def markers(self) -> list[Path]:
        """One file per run the node started, named by its worker's process id."""
        return sorted((self.folder / "markers").iterdir())

    @property
    def scratch(self) -> Path:
        return self.folder / "tmp"


@dataclass
class Cluster:
    address: str
    env: dict[str, str]
    head: Node
    node: Node


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def start_node(folder: Path, arguments: list[str], env: dict[str, str]) -> Node:
    """`ray start ... --block` in a session of its own (so the test can take the whole node down)."""
    for name in ("markers", "tmp", "ray"):
        (folder / name).mkdir(parents=True)
    log = folder / "log"
    process = subprocess.Popen(
        [
            str(RAY),
            "start",
            *arguments,
            "--node-ip-address=127.0.0.1",
            "--num-cpus=1",
            f"--temp-dir={folder / 'ray'}",
            "--disable-usage-stats",
            "--block",
        ],
        env={**env, "FAKE_PIPELINE_MARKERS": str(folder / "markers"), "TMPDIR": str(folder / "tmp")},
        stdout=log.open("w"),
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    deadline = time.monotonic() + 180
    while STARTED not in log.read_text():
        if process.poll() is not None or time.monotonic() > deadline:
            stop(process)
            pytest.fail(f"ray start did not come up:\n{log.read_text()[-2000:]}")
        time.sleep(0.2)
    return Node(process, folder)


def stop(process: subprocess.Popen) -> None:
    """Kill the node: `ray start` and every process of its session (GCS, raylet, agents)."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()


def kill_workers(node: Node) -> None:
    """The worker processes that started runs on ``node`` (Ray gives each a session of its own)."""
    for marker in node.markers:
        with contextlib.suppress(ProcessLookupError):
            os.kill(int(marker.name.split("-")[0]), signal.SIGKILL)


@pytest.fixture(scope="module")
def cluster():
    # Short paths: Ray's sockets live under the temporary folder, and a socket path has at most 107 bytes.
    root = Path(tempfile.mkdtemp(prefix="vsray-"))
    port = free_port()
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT / "tests" / "helpers"), str(ROOT)]),
        "RAY_AUTH_MODE": "token",
        "RAY_AUTH_TOKEN": secrets.token_hex(16),
        "RAY_USAGE_STATS_ENABLED": "0",
        **HEALTH_CHECKS,
    }
    head = start_node(root / "head", ["--head", f"--port={port}", "--include-dashboard=false"], env)
    try:
        node = start_node(root / "node", [f"--address=127.0.0.1:{port}"], {**env, "FAKE_PIPELINE_DOOMED": "1"})
    except BaseException:
        stop(head.process)
        raise
    yield Cluster(f"127.0.0.1:{port}", env, head, node)
    for member in (node, head):
        stop(member.process)
        kill_workers(member)
    shutil.rmtree(root, ignore_errors=True)


def driver(cluster: Cluster, arguments: list[str], cache: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", DRIVER, MODULE, "benchmark", *arguments],
        env={**cluster.env, "VIEWSLAM_CACHE": str(cache)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish(process: subprocess.Popen) -> tuple[int, str]:
    out, err = process.communicate(timeout=300)
    return process.returncode, out + err


def rows(out: Path) -> list[dict]:
    return json.loads((out / "results.json").read_text())


def scores(row: dict) -> dict:
    """A row without its timings (wall-clock, never equal between two runs)."""
    return {key: value for key, value in row.items() if key not in ("time_s", "fps")}


def untimed(block: dict) -> dict:
    return {
        key: [untimed(trial) for trial in value] if key == "trials" else value
        for key, value in block.items()
        if key != "timing"
    }


def test_results_reports_and_recordings_come_back_to_the_driver(cluster, tmp_path):
    folder = write_tum_folder(tmp_path / "tiny", frames=20)
    common = [
        str(folder),
        "--pipeline",
        "fake",
        "--param",
        "wobble_per_seed_m=0.01",
        "--trials",
        str(TRIALS),
        "--quiet",
    ]
    on_cluster = [
        *common,
        "--executor",
        "ray",
        "--ray-address",
        cluster.address,
        "--record",
        "--out",
        str(tmp_path / "cluster"),
    ]
    code, output = finish(driver(cluster, on_cluster, tmp_path / "cache"))
    assert code == 0, output
    ran = {name: len(node.markers) for name, node in (("head", cluster.head), ("node", cluster.node))}
    assert ran["head"] >= 1 and ran["node"] >= 1 and sum(ran.values()) == TRIALS  # both nodes worked

    out = tmp_path / "cluster"
    remote = rows(out)
    assert [(row["trial"], row["seed"], row["status"]) for row in remote] == [(k, k, "ok") for k in range(TRIALS)]
    assert len({row["ate_rmse"] for row in remote}) == TRIALS  # each seed its own run
    for row in remote:
        recording = out / "recordings" / f"tiny.fake.trial{row['trial']}.rrd"
        assert recording.stat().st_size > 0
        report = json.loads(recording.with_suffix(".json").read_text())["pipelines"]["fake"]
        assert report["ate"]["rmse"] == row["ate_rmse"]
        assert recording.with_suffix(".fake.txt").read_text().strip()
    assert (out / "runs" / "tiny.json").is_file() and (out / "report.md").is_file()
    # The tasks recorded into their nodes' own scratch space and cleared it.
    assert not [*cluster.head.scratch.glob("viewslam-task-*"), *cluster.node.scratch.glob("viewslam-task-*")]

    local_out = tmp_path / "local"
    code, output = finish(
        driver(cluster, [*common, "--jobs", "2", "--no-cache", "--record", "--out", str(local_out)], tmp_path / "cache")
    )
    assert code == 0, output
    assert [scores(row) for row in rows(local_out)] == [scores(row) for row in remote]
    assert sorted(path.name for path in (local_out / "recordings").iterdir()) == sorted(
        path.name for path in (out / "recordings").iterdir()
    )  # the same files in the same places
    blocks = [json.loads((where / "runs" / "tiny.json").read_text())["pipelines"]["fake"] for where in (out, local_out)]
    assert untimed(blocks[0]) == untimed(blocks[1]) and len(blocks[0]["trials"]) == TRIALS

    before = (out / "results.json").read_bytes()
    code, output = finish(driver(cluster, on_cluster, tmp_path / "cache"))
    assert code == 0, output
    assert len(cluster.head.markers) + len(cluster.node.markers) == TRIALS  # the re-run ran nothing
    assert (out / "results.json").read_bytes() == before  # every row, timings included, from the cache


def test_a_node_lost_mid_run_fails_its_tasks_and_the_others_complete(cluster, tmp_path):
    """Runs last: it takes the second node down. Its tasks hang there until it goes."""
    folder = write_tum_folder(tmp_path / "tiny", frames=20)
    head_before, node_before = len(cluster.head.markers), len(cluster.node.markers)
    arguments = [
        str(folder),
        "--pipeline",
        "fake",
        "--param",
        "fail=hang_where_doomed",
        "--trials",
        str(TRIALS),
        "--executor",
        "ray",
        "--ray-address",
        cluster.address,
        "--record",
        "--out",
        str(tmp_path / "out"),
        "--quiet",
    ]
    running = driver(cluster, arguments, tmp_path / "cache")
    deadline = time.monotonic() + 120
    while len(cluster.node.markers) == node_before:  # a task hangs on the doomed node
        assert running.poll() is None and time.monotonic() < deadline, running.communicate()
        time.sleep(0.2)
    stop(cluster.node.process)
    kill_workers(cluster.node)
    code, output = finish(running)
    assert code == 1, output  # a task failed, the others completed

    lost = len(cluster.node.markers) - node_before
    results = rows(tmp_path / "out")
    failed = [row for row in results if row["status"] == "failed"]
    assert len(results) == TRIALS and len(failed) == lost
    assert all(row["trial"] is not None for row in failed)
    report = (tmp_path / "out" / "report.md").read_text()
    assert len(re.findall(r"trial \d \(seed \d\): (NodeDiedError|WorkerCrashedError)", report)) == lost, report
    recorded = sorted(path.name for path in (tmp_path / "out" / "recordings").glob("*.rrd"))
    assert recorded == [f"tiny.fake.trial{row['trial']}.rrd" for row in results if row["status"] == "ok"]

    # A re-run retries only the failed tasks, now on the head alone.
    code, output = finish(driver(cluster, arguments, tmp_path / "cache"))
    assert code == 0, output
    assert [row["status"] for row in rows(tmp_path / "out")] == ["ok"] * TRIALS
    assert len(cluster.head.markers) - head_before == TRIALS  # the first run's on the head, then the retried
