"""Human walking: recorded gait in the biomechanist's conventions, a planned step's stride in
the same terms, and the comparison (metrics, table, picture).

``read_recording`` (Winter's appendix workbook or a plain CSV), ``step_stride`` (the stride of
a planned step's stance leg from its exported samples), ``compare_gait`` (the metrics),
``problems.human.plots.comparison_figure`` (the picture).
"""

from problems.human.comparison import GaitComparison, compare_gait
from problems.human.reading import read_recording
from problems.human.recording import CHANNELS, GaitRecording, read_csv, write_csv
from problems.human.stride import step_stride
from problems.human.winter import read_winter

__all__ = [
    "CHANNELS",
    "GaitComparison",
    "GaitRecording",
    "compare_gait",
    "read_csv",
    "read_recording",
    "read_winter",
    "step_stride",
    "write_csv",
]
