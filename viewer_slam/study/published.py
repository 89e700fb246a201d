"""Read what the study published: the result logs of TUM's scripts and the bars of its chart scripts.

The numbers are kept with the number of decimals they were printed with, so a reproduced
figure is compared at exactly the precision the author could see.
"""

import ast
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError


@dataclass(frozen=True)
class Printed:
    """A published number and its printed decimals (``0.449568`` → 6)."""

    value: float
    decimals: int

    @classmethod
    def parse(cls, text: str) -> "Printed":
        _, _, fraction = text.partition(".")
        return cls(float(text), len(fraction))

    def agrees(self, value: float | None) -> bool:
        """Whether ``value`` prints as this number at its decimals."""
        return value is not None and f"{value:.{self.decimals}f}" == f"{self.value:.{self.decimals}f}"

    def to_json(self) -> float:
        return self.value


def _block(text: str, start: str, end: str | None) -> str:
    """The text from the line ``start`` to the line ``end`` (or the end of the text)."""
    found = re.search(rf"^{start}\s*$", text, re.MULTILINE)
    if found is None:
        return ""
    rest = text[found.end() :]
    stop = re.search(rf"^{end}\s*$", rest, re.MULTILINE) if end else None
    return rest[: stop.start()] if stop else rest


def parse_log(path: Path) -> dict[str, Printed]:
    """The figures of one result log: ``time_s``, ``ate_pairs``, ``ate_rmse``, ``rpe_pairs``,
    ``rpe_trans_rmse``, ``rpe_rot_rmse_deg`` (those it holds).

    The logs are hand-assembled: "Time taken:" on its own line or "Time Taken: 76.3s", then
    the output of evaluate_ate.py --verbose under "ATE" and of evaluate_rpe.py --verbose
    under "RPE" (one also carries RTAB-Map's own report first, which is not the study's figure).
    """
    text = path.read_text(errors="replace")
    figures = {}
    time = re.search(r"Time taken:\s*([\d.]+)", text, re.IGNORECASE)
    if time:
        figures["time_s"] = Printed.parse(time.group(1))
    ate, rpe = _block(text, "ATE", "RPE"), _block(text, "RPE", None)
    for block, prefix, keys in (
        (ate, "ate", {"absolute_translational_error.rmse": "ate_rmse"}),
        (rpe, "rpe", {"translational_error.rmse": "rpe_trans_rmse", "rotational_error.rmse": "rpe_rot_rmse_deg"}),
    ):
        pairs = re.search(r"compared_pose_pairs (\d+) pairs", block)
        if pairs:
            figures[f"{prefix}_pairs"] = Printed(float(pairs.group(1)), 0)
        for line, key in keys.items():
            found = re.search(rf"^{re.escape(line)} ([\d.]+)", block, re.MULTILINE)
            if found:
                figures[key] = Printed.parse(found.group(1))
    if "ate_rmse" not in figures and "rpe_trans_rmse" not in figures:
        raise InputError.at(path, "not a result log of TUM's evaluate_ate.py / evaluate_rpe.py (no ATE or RPE block)")
    return figures


def _source_of(source: str, node: ast.expr) -> str:
    """The text of ``node``; parsed from ``source``, it always carries its position."""
    segment = ast.get_source_segment(source, node)
    assert segment is not None
    return segment


def parse_chart(path: Path, variables: tuple[str, ...]) -> tuple[list[str], dict[str, list[Printed]]]:
    """The x tick labels (newlines removed) and, for each of ``variables``, the bar heights of a chart
    script (``rgbd = [ ... ]``), read from its syntax tree, never run."""
    try:
        tree = ast.parse(path.read_text())
    except (SyntaxError, ValueError) as error:
        raise InputError.at(path, f"not a Python chart script: {error}") from None
    source = path.read_text()
    bars, labels = {}, None
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Assign)
            and len(node.targets) == 1
            and isinstance(node.targets[0], ast.Name)
            and node.targets[0].id in variables
            and isinstance(node.value, ast.List)
        ):
            bars[node.targets[0].id] = [
                Printed.parse(_source_of(source, element).strip()) for element in node.value.elts
            ]
        if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "xticks" and len(node.args) == 2:
            labels = [" ".join(str(value).replace("/\n", "/").split()) for value in ast.literal_eval(node.args[1])]
    missing = [name for name in variables if name not in bars]
    if labels is None or missing:
        raise InputError.at(path, f"chart script without {'xticks labels' if labels is None else missing[0]}")
    if any(len(values) != len(labels) for values in bars.values()):
        raise InputError.at(path, "chart script has a different number of bars and labels")
    return labels, bars
