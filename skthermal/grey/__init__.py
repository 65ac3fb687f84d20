"""Grey-system building blocks: AGO/IAGO, GM(1,1), GM(0,N), GM(1,N), grey
relational analysis."""

from skthermal.grey._ago import ago, background, iago
from skthermal.grey._models import GM11, gm0n, gm1n, gm11
from skthermal.grey._relational import grey_relational_grade

__all__ = [
    "GM11",
    "ago",
    "background",
    "gm0n",
    "gm11",
    "gm1n",
    "grey_relational_grade",
    "iago",
]
