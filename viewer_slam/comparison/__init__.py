"""Two runs of one sequence compared frame by frame (`viewslam diff`, `viewslam benchmark --compare`)."""

from .compare import Comparison, RunComparison, compare_reports
from .output import comparison_to_dict, markdown_comparison, print_comparison
from .reports import RecordReport, load_report
from .results import BenchmarkResults, ResultsComparison, compare_results, load_results

__all__ = [
    "BenchmarkResults",
    "Comparison",
    "RecordReport",
    "ResultsComparison",
    "RunComparison",
    "compare_reports",
    "compare_results",
    "comparison_to_dict",
    "load_report",
    "load_results",
    "markdown_comparison",
    "print_comparison",
]
