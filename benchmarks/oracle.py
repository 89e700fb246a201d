"""viewslam's rtabmap beside the real RTAB-Map 0.23.8, run here on the very same frames.

    python -m benchmarks.oracle --oracle ../shared/oracles/rtabmap-0.23.8 \\
        --scene 360_kidnap --seeds 0 1 2 --runs 3 --rules ros tool --out recordings/oracle

For each scene and seed the scene is rendered (``viewslam synth SCENE --resolution 640x480
--seed S``, its own length unless ``--frames``, into a folder whose name carries ``freiburg3``: the original reads its
intrinsics from the name) and the SHA-256 of every frame is listed; the original runs ``--runs``
times under each loss rule (``tool``: its dataset tool, a new map on every lost frame; ``ros``:
``RTABMAP_NO_NEW_MAP=1``, a loss its odometry recovers from continues the map, as rtabmap_ros
does), ours ``--our-runs`` times under the same rule (``ros``: the defaults; ``tool``:
viewslam/NewMapOnLoss) with the pipeline seeds 0, 1, ... (the seed draws our k-d trees, as
the original's random device draws its own),
both at the defaults (``--mode default``) or with a node on every frame (``--mode perframe``);
ours then takes ``--config`` and ``--param`` as ``viewslam record`` does, on top of the rule's.
Before every run the frames are checked against the list: the comparison is refused if any
differ. Each table gives the min–max over the runs of each, and our seed 0's value (`viewslam
record`'s default) where it is not the only one.

Per run: where odometry resumes after each loss (frame and inliers), the maps and how many
loop closures or proximity links join them (and whether every map is joined to the first),
loop closures and proximity links, ATE over the graph nodes, over every pose written and of
the nodes' odometry. The original's per-frame odometry comes from its console (one
``Iteration`` line per frame, lost when it warns that odometry was reset), everything else
from its database through viewslam's own reader (``--estimate NAME=rtabmap.db``).

Writes ``OUT/<scene>-s<seed>-<mode>-<rule>.json`` and ``OUT/tables.md``; with ``--docs``, the
tables replace the block ``<!-- oracle: <scene> -->`` (or ``--block``'s) of
docs/pipelines/rtabmap.md.
"""

import argparse
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.sources import RgbdSequence, open_source
from viewer_slam.dataset.synth import generate_scenario
from viewer_slam.errors import InputError
from viewer_slam.geometry.rtabmap_database import read_rtabmap_database
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.pipelines.events import Event, FrameTracked, GraphEdge, KeyframeAdded, TrackingRecovered
from viewer_slam.pipelines.params import parse_assignments

from . import lab
from .figures import REPO, invocation, stamp, write_block, written
from .reference import PER_FRAME, THAT_BUILD

ORACLE = REPO.parent / "shared" / "oracles" / "rtabmap-0.23.8"
DOCS = REPO / "docs" / "pipelines" / "rtabmap.md"
TOOL = "rtabmap-rgbd_dataset"
ORIGINAL = "RTAB-Map 0.23.8"
RULE_PARAMS = {"ros": {}, "tool": {"viewslam/NewMapOnLoss": "true"}}
LIKE_FOR_LIKE = {**THAT_BUILD, "viewslam/LinkCovariance": "own"}
"""The oracle's configuration: its build has no g2o, its dataset tool links a location with
that frame's own registration covariance."""
RULE_ENV = {"ros": {"RTABMAP_NO_NEW_MAP": "1"}, "tool": {}}
RULE_TEXT = {
    "ros": "ROS rule (a loss odometry recovers from continues the map)",
    "tool": "dataset tool's rule (a new map on every lost frame)",
}
ITERATION = re.compile(r"Iteration (\d+)/\d+: .*odom\(quality=(-?\d+)/(\d+)")
LOST_LINE = "Odometry is reset"
JOINING = ("global_loop", "local_space")


# -- the frames ---------------------------------------------------------------------------------


def render(scene: str, seed: int, frames: int | None, into: Path) -> Path:
    """The scene's TUM folder (rendered once), named so that the original reads fr3's intrinsics."""
    folder = into / f"s{seed}" / f"rgbd_dataset_freiburg3_synth_{scene}"
    if not (folder / "rgb.txt").is_file():
        generate_scenario(scene, folder, frames=frames, resolution=(640, 480), seed=seed, camera="fr3", progress=True)
    return folder


def frame_digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every colour and depth image, by path under the folder."""
    return {
        str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest()
        for kind in ("rgb", "depth")
        for path in sorted((folder / kind).glob("*.png"))
    }


def check_frames(folder: Path, listed: dict[str, str]) -> None:
    """Refuse frames that differ from ``listed`` (path under the folder -> SHA-256)."""
    now = frame_digests(folder)
    differing = sorted(name for name in listed.keys() | now.keys() if listed.get(name) != now.get(name))
    if differing:
        raise InputError(
            f"{folder}: {len(differing)} frames differ from the listed SHA-256 (first: {differing[0]}); "
            f"no comparison on different frames"
        )


def synced(oracle: Path, folder: Path) -> None:
    """``rgb_sync/`` and ``depth_sync/``, which the dataset tool reads, made by the oracle's own
    ``sync.py`` (each colour frame with the nearest depth frame within 20 ms)."""
    if not (folder / "rgb_sync").is_dir():
        subprocess.run([sys.executable, str(oracle / "sync.py"), str(folder)], check=True, stdout=subprocess.DEVNULL)


# -- the original -------------------------------------------------------------------------------


def library_path(oracle: Path, scratch: Path) -> str:
    """The oracle's libraries, with its versioned names restored as links where the copy at hand
    holds them as small text files naming their target (a checkout without symbolic links)."""
    links = scratch / "lib"
    links.mkdir(exist_ok=True)
    for path in (oracle / "lib").glob("*.so*"):
        if path.stat().st_size < 256 and not path.read_bytes().startswith(b"\x7fELF"):
            target = oracle / "lib" / path.read_text().strip()
            if target.is_file() and not (links / path.name).exists():
                (links / path.name).symlink_to(target)
    return f"{links}:{oracle / 'lib'}"


def run_original(oracle: Path, folder: Path, out: Path, rule: str, mode: str, scratch: Path) -> Path:
    """One run of the dataset tool; its database and console in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    if not (out / "rtabmap.db").is_file():
        arguments = (
            [arg for key, value in PER_FRAME.items() for arg in (f"--{key}", str(value))] if mode == "perframe" else []
        )
        environment = {**os.environ, **RULE_ENV[rule], "LD_LIBRARY_PATH": library_path(oracle, scratch)}
        with open(out / "console.log", "w") as console:
            subprocess.run(
                [str(oracle / "bin" / TOOL), "--output", str(out), *arguments, folder.name],
                cwd=folder.parent,
                env=environment,
                stdout=console,
                stderr=subprocess.STDOUT,
                check=True,
            )
    return out


def original_frames(console: Path) -> list[tuple[bool, int]]:
    """Per frame read: (lost, inliers) from the tool's console."""
    frames, lost = [], False
    for line in console.read_text(errors="replace").splitlines():
        if LOST_LINE in line:
            lost = True
        match = ITERATION.search(line)
        if match:
            frames.append((lost, max(int(match.group(2)), 0)))
            lost = False
    return frames


def summarise_original(run: Path, sequence) -> dict:
    database = read_rtabmap_database(run / "rtabmap.db")
    map_of = {node.id: node.map_id for node in database.nodes}
    joining = [
        (map_of[link.from_id], map_of[link.to_id])
        for link in database.links
        if link.kind in JOINING and map_of[link.from_id] != map_of[link.to_id]
    ]
    per_frame = original_frames(run / "console.log")
    return {
        "resumptions": resumptions([lost for lost, _ in per_frame], [inliers for _, inliers in per_frame]),
        "maps": len(set(map_of.values())),
        "joining_links": len(joining),
        "all_joined": all_joined(sorted(set(map_of.values())), joining),
        "loop_closures": sum(link.kind == "global_loop" for link in database.links),
        "proximity": sum(link.kind == "local_space" for link in database.links),
        "nodes": len(database.nodes),
        "node_ate": ate_cm(sequence, database.trajectory()),
        "odometry_ate": ate_cm(sequence, database.trajectory(optimised=False)),
    }


# -- ours ---------------------------------------------------------------------------------------


def summarise_ours(
    folder: Path, rule: str, mode: str, options: argparse.Namespace, seed: int, like_for_like: bool = False
) -> dict:
    sequence = open_source(folder)
    preset: dict[str, Any] = {
        **(LIKE_FOR_LIKE if like_for_like else {}),
        **RULE_PARAMS[rule],
        **(PER_FRAME if mode == "perframe" else {}),
    }
    events: list[Event] = []
    spec = lab.pipeline_spec("rtabmap", options, preset=preset, seed=seed)
    scored = lab.run(sequence, spec, "rtabmap", sinks=[events.append])
    run, evaluation = scored.run, scored.evaluation
    tracked = sorted((event for event in events if isinstance(event, FrameTracked)), key=lambda e: e.frame_index)
    session, session_of = 0, {}
    for event in sorted(
        (e for e in events if isinstance(e, (KeyframeAdded, TrackingRecovered))),
        key=lambda e: (e.frame_index, isinstance(e, KeyframeAdded)),
    ):
        if isinstance(event, TrackingRecovered) and "new map" in event.reason:
            session += 1
        elif isinstance(event, KeyframeAdded):
            session_of[event.keyframe_id] = session
    closures = [
        event
        for event in events
        if isinstance(event, GraphEdge) and event.accepted and event.detection in ("appearance", "proximity")
    ]
    joining = [
        (session_of[e.from_keyframe], session_of[e.to_keyframe])
        for e in closures
        if session_of.get(e.from_keyframe) != session_of.get(e.to_keyframe)
    ]
    nodes = np.isin(run.frame_indices, run.node_frames)
    return {
        "resumptions": resumptions([event.pose is None for event in tracked], [event.inliers for event in tracked]),
        "maps": len(set(session_of.values())),
        "joining_links": len(joining),
        "all_joined": all_joined(sorted(set(session_of.values())), joining),
        "loop_closures": sum(e.detection == "appearance" for e in closures),
        "proximity": sum(e.detection == "proximity" for e in closures),
        "nodes": int(nodes.sum()),
        "node_ate": 100 * evaluation.node_ate.stats()["rmse"] if evaluation and evaluation.node_ate else None,
        "frame_ate": 100 * evaluation.ate.stats()["rmse"] if evaluation and evaluation.ate else None,
        "odometry_ate": ate_cm(sequence, run.odometry.subset(nodes)) if run.odometry is not None else None,
    }


# -- shared -------------------------------------------------------------------------------------


def resumptions(lost: list[bool], inliers: list[int]) -> list[tuple[int, int]]:
    """(frame, inliers) of each frame that registers after lost ones."""
    return [(frame, inliers[frame]) for frame in range(1, len(lost)) if lost[frame - 1] and not lost[frame]]


def all_joined(maps: list[int], links: list[tuple[int, int]]) -> bool:
    """Whether the links join every map to the first (through others)."""
    joined, grown = {maps[0]} if maps else set(), True
    while grown:
        grown = False
        for a, b in links:
            if (a in joined) != (b in joined):
                joined |= {a, b}
                grown = True
    return joined == set(maps)


def ate_cm(sequence: RgbdSequence, trajectory: Trajectory) -> float | None:
    """ATE RMSE in cm; None for fewer than 3 poses or none paired with the groundtruth."""
    rmse = lab.ate_rmse(sequence.groundtruth, trajectory) if len(trajectory) >= 3 else float("nan")
    return None if math.isnan(rmse) else 100 * rmse


def spread(values: list, digits: int = 2) -> str:
    """The min–max of ``values`` (None left out, "–" for none), a float to ``digits`` decimals;
    one value where both ends read the same."""
    values = [value for value in values if value is not None]
    if not values:
        return "–"
    text = (lambda v: f"{v:.{digits}f}") if isinstance(min(values), float) else str
    low, high = text(min(values)), text(max(values))
    return low if low == high else f"{low}–{high}"


def resumption_text(resumed: list[tuple[int, int]]) -> str:
    return " / ".join(f"{frame} ({inliers})" for frame, inliers in resumed) or "never"


def resumption_spread(originals: list[dict], k: int) -> str:
    """The k-th resumption's frame and inliers over the runs that have one, and how many do."""
    having = [run["resumptions"][k] for run in originals if k < len(run["resumptions"])]
    text = f"{spread([frame for frame, _ in having])} ({spread([inliers for _, inliers in having])})"
    return text if len(having) == len(originals) else f"{text} in {len(having)} of {len(originals)} runs"


def table(title: str, ours: list[dict], originals: list[dict]) -> str:
    """Ours (run with the seeds 0, 1, ...: the first is `viewslam record`'s default) beside the
    original's runs, each as its min–max."""
    rows = [("resumes at frame (inliers)", resumptions_text(ours), resumptions_text(originals))]
    for key, label in (
        ("maps", "maps"),
        ("joining_links", "loop closures and proximity links between maps"),
        ("all_joined", "every map joined to the first"),
        ("loop_closures", "loop closures"),
        ("proximity", "proximity links"),
        ("nodes", "nodes"),
        ("node_ate", "ATE over the nodes (cm)"),
        ("odometry_ate", "the nodes' odometry, ATE (cm)"),
    ):
        rows.append((label, with_default(ours, key), spread([run[key] for run in originals])))
    if ours[0].get("frame_ate") is not None:
        rows.append(("ATE over every pose written (cm)", with_default(ours, "frame_ate"), "–"))
    lines = [
        f"**{title}**",
        "",
        f"| | ours, {counted(len(ours), 'seed')} (min–max; seed 0) | {ORIGINAL}, {counted(len(originals), 'run')} "
        "(min–max) |",
        "|---|---|---|",
    ]
    lines += [f"| {label} | {mine} | {theirs} |" for label, mine, theirs in rows]
    return "\n".join(lines)


def resumptions_text(runs: list[dict]) -> str:
    """Each resumption's spread over the runs that have it, or "never"."""
    count = max(len(run["resumptions"]) for run in runs)
    return " / ".join(resumption_spread(runs, k) for k in range(count)) or "never"


def counted(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


def with_default(ours: list[dict], key: str) -> str:
    """The spread of ``key`` over our runs and, when they differ, seed 0's value."""
    text = spread([run[key] for run in ours])
    return text if len(ours) == 1 or spread([ours[0][key]]) == text else f"{text}; {spread([ours[0][key]])}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.oracle", description=__doc__.split("\n\n")[0])
    parser.add_argument("--oracle", type=Path, default=ORACLE, help="the RTAB-Map 0.23.8 build (bin/, lib/)")
    parser.add_argument("--scene", default="360_kidnap")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--frames", type=int, help="frames to render (default: the scenario's own length)")
    parser.add_argument("--runs", type=int, default=3, help="runs of the original per seed, rule and mode")
    parser.add_argument(
        "--our-runs", type=int, default=3, help="runs of ours, with the pipeline seeds 0, 1, ... (its k-d trees' draws)"
    )
    parser.add_argument("--rules", nargs="+", choices=sorted(RULE_PARAMS), default=["ros", "tool"])
    parser.add_argument("--mode", choices=["default", "perframe"], default="default")
    parser.add_argument(
        "--like-for-like",
        action="store_true",
        help="ours in the oracle's configuration: " + ", ".join(f"{k}={v}" for k, v in LIKE_FOR_LIKE.items()),
    )
    lab.add_parameter_options(parser, "ours, on top of the rule's")
    parser.add_argument("--out", type=Path, default=Path("recordings/oracle"))
    parser.add_argument("--docs", action="store_true", help="write the tables into docs/pipelines/rtabmap.md")
    parser.add_argument("--block", help="the docs block to write (default: the scene's name)")
    args = parser.parse_args(argv)
    arguments = lab.arguments(argv)
    if not (args.oracle / "bin" / TOOL).is_file():
        raise InputError(f"{args.oracle}: no bin/{TOOL}; give --oracle the RTAB-Map 0.23.8 folder")
    block = args.block or args.scene
    if args.docs:
        try:
            written(DOCS.read_text(), block, "oracle")
        except ValueError as error:
            raise InputError(f"{DOCS}: {error}") from None
    lab.pipeline_spec("rtabmap", args)  # the parameters checked before the first render
    extra = parse_assignments(args.param)
    sections = []
    with tempfile.TemporaryDirectory() as scratch:
        for seed in args.seeds:
            folder = render(args.scene, seed, args.frames, args.out / "frames")
            listed_path = folder.parent / f"{folder.name}.sha256"
            if not listed_path.is_file():
                listed_path.write_text("".join(f"{digest}  {name}\n" for name, digest in frame_digests(folder).items()))
            listed = {
                name: digest for digest, name in (line.split("  ", 1) for line in listed_path.read_text().splitlines())
            }
            synced(args.oracle, folder)
            sequence = open_source(folder)
            for rule in args.rules:
                originals = []
                for k in range(1, args.runs + 1):
                    check_frames(folder, listed)
                    run = run_original(
                        args.oracle,
                        folder,
                        args.out / "original" / f"{args.scene}-s{seed}-{args.mode}-{rule}-{k}",
                        rule,
                        args.mode,
                        Path(scratch),
                    )
                    originals.append(summarise_original(run, sequence))
                check_frames(folder, listed)
                ours = [
                    summarise_ours(folder, rule, args.mode, args, seed=k, like_for_like=args.like_for_like)
                    for k in range(args.our_runs)
                ]
                result = {
                    "scene": args.scene,
                    "seed": seed,
                    "mode": args.mode,
                    "rule": rule,
                    "ours": ours,
                    "original": originals,
                    "frames_sha256": str(listed_path),
                    "overrides": extra,
                }
                (
                    args.out / f"{args.scene}-s{seed}-{args.mode}-{rule}{'-' + args.block if args.block else ''}.json"
                ).write_text(json.dumps(result, indent=1) + "\n")
                settings = ", ".join(
                    f"{key}={value}"
                    for key, value in {**(LIKE_FOR_LIKE if args.like_for_like else {}), **extra}.items()
                )
                sections.append(
                    table(
                        f"{args.scene}, seed {seed}, {args.mode}, {RULE_TEXT[rule]}"
                        + (f"; ours with {settings}" if settings else ""),
                        ours,
                        originals,
                    )
                )
                print(sections[-1] + "\n", flush=True)
    command = invocation(parser.prog, [arg for arg in arguments if arg != "--docs"])
    text = "\n\n".join(sections) + f"\n\n{stamp(command)}"
    (args.out / "tables.md").write_text(text + "\n")
    if args.docs:
        write_block(DOCS, block, text, "oracle")
    return 0


if __name__ == "__main__":
    lab.main_of(main)
