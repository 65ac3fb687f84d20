"""A truth machine independent of skthermal's simulator, for the gap diagnosis.

A vertical milling centre with a finite-difference network, its own heat
inputs, thermo-elastic map and effect implementations (numpy and scipy
only), writing run tables with the ``vmc-b`` preset's column names.
"""

from .campaign import (
    CASES,
    make_truth_campaign,
    random_blocks,
    random_room,
    warm_run_table,
)
from .effects import EFFECTS, TruthEffect
from .vmc_truth import Block, TruthMachine

__all__ = [
    "CASES",
    "EFFECTS",
    "Block",
    "TruthEffect",
    "TruthMachine",
    "make_truth_campaign",
    "random_blocks",
    "random_room",
    "warm_run_table",
]
