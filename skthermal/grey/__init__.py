"""Grey-system building blocks and regressors: AGO/IAGO, GM(1,1), GM(0,N),
GM(1,N), grey relational analysis, GMC(1,N) and GNNMCI(1,N)."""

from skthermal.grey._ago import ago, background, iago
from skthermal.grey._gmc import (
    gmc1n,
    gmc1n_predict,
    gmc_time_response,
    gnnmci_layers,
    gnnmci_predict,
    gnnmci_time_response,
)
from skthermal.grey._models import GM11, gm0n, gm1n, gm11
from skthermal.grey._regressors import GNNMCIRegressor, GreyPSORegressor
from skthermal.grey._relational import grey_relational_grade
from skthermal.grey._varpro import gmc1n_varpro

__all__ = [
    "GM11",
    "GNNMCIRegressor",
    "GreyPSORegressor",
    "ago",
    "background",
    "gm0n",
    "gm11",
    "gm1n",
    "gmc1n",
    "gmc1n_predict",
    "gmc1n_varpro",
    "gmc_time_response",
    "gnnmci_layers",
    "gnnmci_predict",
    "gnnmci_time_response",
    "grey_relational_grade",
    "iago",
]
