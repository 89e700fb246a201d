"""Two runs of one sequence compared frame by frame (`viewslam diff`)."""

from .compare import Comparison, RunComparison, compare_reports
from .output import comparison_to_dict, print_comparison
from .reports import RecordReport, load_report

__all__ = ["Comparison", "RecordReport", "RunComparison", "compare_reports", "comparison_to_dict", "load_report",
           "print_comparison"]
