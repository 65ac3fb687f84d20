"""The papers' Machine B study on the simulator, and the papers' metrics per run.

:func:`reproduce` repeats the study of 001 §5.3 (sensor selection and ANFIS,
grey and neural-network models trained on Test IV, scored on Tests I, II, III,
V and VI) on the simulated ``"vmc-b"`` machine and writes a report folder;
``skthermal reproduce`` runs it. :func:`score_runs` computes the papers'
metrics per run on changes since the run start.
"""

from skthermal.study._constants import PAPER, PAPER_SENSORS
from skthermal.study._machine_b import StudyResult, reproduce
from skthermal.study._scoring import METRIC_COLUMNS, score_runs

__all__ = [
    "METRIC_COLUMNS",
    "PAPER",
    "PAPER_SENSORS",
    "StudyResult",
    "reproduce",
    "score_runs",
]
