"""Screen-space ambient occlusion passes, one module per method.

* :mod:`.vector` — the vector-based method of Scheer & Keutel (D2)
* :mod:`.ssao` — standard normal-oriented hemisphere SSAO (D3)
* :mod:`.crytek` — Crytek SSAO, a whole sphere without normal (Mittring 2007; thesis 4.3.1)
* :mod:`.hbao` — horizon-based AO (Bavoil & Sainz 2008)
* :mod:`.alchemy` — Alchemy AO (McGuire et al. 2011)
"""

from .alchemy import AlchemyAO
from .base import AOPass
from .crytek import CrytekAO
from .hbao import HBAO
from .ssao import StandardSSAO
from .vector import VectorAO

AO_METHODS = {"vector": VectorAO, "ssao": StandardSSAO, "crytek": CrytekAO, "hbao": HBAO, "alchemy": AlchemyAO}

__all__ = ["AOPass", "AO_METHODS", "VectorAO", "StandardSSAO", "CrytekAO", "HBAO", "AlchemyAO"]
