"""Screen-space ambient occlusion passes, one module per method.

* :mod:`.vector` — the vector-based method of Scheer & Keutel (D2)
* :mod:`.ssao` — standard normal-oriented hemisphere SSAO (D3)
* :mod:`.crytek` — Crytek SSAO, a whole sphere without normal (Mittring 2007; thesis 4.3.1)
* :mod:`.hbao` — horizon-based AO (Bavoil & Sainz 2008)
* :mod:`.alchemy` — Alchemy AO (McGuire et al. 2011)
"""

from mrcheck.render.ao.alchemy import AlchemyAO
from mrcheck.render.ao.base import AOPass
from mrcheck.render.ao.crytek import CrytekAO
from mrcheck.render.ao.hbao import HBAO
from mrcheck.render.ao.ssao import StandardSSAO
from mrcheck.render.ao.vector import VectorAO

AO_METHODS = {"vector": VectorAO, "ssao": StandardSSAO, "crytek": CrytekAO, "hbao": HBAO, "alchemy": AlchemyAO}

__all__ = ["AOPass", "AO_METHODS", "VectorAO", "StandardSSAO", "CrytekAO", "HBAO", "AlchemyAO"]
