"""The same bytes on every x86-64 machine with AVX2: the reference runs (the built-in demo and
the 200-frame fr1/rpy excerpt, both pipelines) give the committed digests of
tests/reference_runs/ here, and again under emulated machines whose libraries take other
code paths (`python -m scripts.reference_runs`). A machine that computes differently is named by the
first file and frame that differ."""

import os
import subprocess
import sys

from viewer_slam.code_paths import guaranteed

import pytest

from scripts import reference_runs

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        not reference_runs.TUM_RPY_200.is_dir(), reason="shared TUM excerpt not present beside the repository"
    ),
]
x86_with_avx2 = pytest.mark.skipif(not guaranteed(), reason="the guarantee is for x86-64 with AVX2")


@x86_with_avx2
def test_the_reference_runs_give_the_committed_bytes(tmp_path):
    assert reference_runs.differences(reference_runs.record_runs(tmp_path)) == []


@x86_with_avx2
def test_emulated_machines_give_the_committed_bytes(tmp_path):
    machines = reference_runs.runnable(reference_runs.MACHINES)
    assert machines  # at least the machine without AVX-512: the guarantee's processors all run it
    found = {
        name: reference_runs.differences(reference_runs.record_runs(tmp_path / str(number), environment))
        for number, (name, environment) in enumerate(machines.items())
    }
    assert found == {name: [] for name in machines}


def test_a_changed_pose_is_named_with_its_frame(tmp_path):
    reference = reference_runs.REFERENCE
    lines = (reference / "demo.rtabmap.txt").read_text().splitlines(keepends=True)
    stamp = lines[40].split()[0]
    lines[40] = lines[40].replace(lines[40].split()[1], "9.999999", 1)
    (tmp_path / "demo.rtabmap.txt").write_text("".join(lines))
    found = {**reference_runs.read_sums(reference / "SHA256SUMS"), "demo.rtabmap.txt": "another digest"}
    assert reference_runs.compare(found, tmp_path) == [
        f"demo.rtabmap.txt differs: first differs at line 41, the pose at {stamp} (this run: {stamp})"
    ]
    assert reference_runs.compare(
        {
            **found,
            "demo.rtabmap.txt": reference_runs.read_sums(reference / "SHA256SUMS")["demo.rtabmap.txt"],
            "demo figures": "another",
        },
        tmp_path,
    ) == ["demo figures differs"]


@x86_with_avx2
def test_viewslam_holds_numpy_and_openblas_to_one_code_path_and_warns_when_it_cannot():
    from viewer_slam import code_paths

    assert code_paths.numpy_level() == "X86_V3"  # this suite's own process: the conftest imports viewer_slam first
    assert os.environ["OPENBLAS_CORETYPE"] == "Haswell"
    unheld = {name: value for name, value in os.environ.items() if name not in code_paths.environment()}
    opencv = subprocess.run(
        [sys.executable, "-c", "import viewer_slam, cv2; print(cv2.getCPUFeaturesLine())"],
        env=unheld,
        capture_output=True,
        text=True,
        check=True,
    )
    assert "OPENCV" not in opencv.stderr  # every name taken, none unavailable here
    assert ("AVX512-SKX?" in opencv.stdout) == ("AVX512-SKX" in opencv.stdout)  # off wherever the CPU has it
    late = subprocess.run(
        [sys.executable, "-c", "import numpy, warnings; warnings.simplefilter('error'); import viewer_slam"],
        env=unheld,
        capture_output=True,
        text=True,
        check=False,
    )
    first = subprocess.run(
        [sys.executable, "-c", "import viewer_slam.code_paths as c; import numpy; print(c.numpy_level())"],
        env=unheld,
        capture_output=True,
        text=True,
        check=True,
    )
    assert first.stdout.strip() == "X86_V3"
    beyond = set(reference_runs.AVX512) <= reference_runs.cpu_flags()
    assert (late.returncode != 0 and "NumPy was imported before viewer_slam" in late.stderr) == beyond
