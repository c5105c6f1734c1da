"""Screen-space ambient occlusion passes, one module per method.

* :mod:`.vector` — the vector-based method of Scheer & Keutel (D2)
* :mod:`.ssao` — standard normal-oriented hemisphere SSAO (D3)
* :mod:`.crytek` — Crytek SSAO, a whole sphere without normal (Mittring 2007; thesis 4.3.1)
* :mod:`.hbao` — horizon-based AO (Bavoil & Sainz 2008)
* :mod:`.alchemy` — Alchemy AO (McGuire et al. 2011)
* :mod:`.gtao` — ground-truth-based AO, GTAO (Jimenez et al. 2016)
* :mod:`.vbao` — visibility-bitmask AO (Therrien et al. 2023)
"""

from mrcheck.render.ao.alchemy import AlchemyAO
from mrcheck.render.ao.base import AOPass
from mrcheck.render.ao.crytek import CrytekAO
from mrcheck.render.ao.gtao import GTAO
from mrcheck.render.ao.hbao import HBAO
from mrcheck.render.ao.ssao import StandardSSAO
from mrcheck.render.ao.vbao import VBAO
from mrcheck.render.ao.vector import VectorAO

AO_METHODS = {
    "vector": VectorAO,
    "ssao": StandardSSAO,
    "crytek": CrytekAO,
    "hbao": HBAO,
    "alchemy": AlchemyAO,
    "gtao": GTAO,
    "vbao": VBAO,
}

__all__ = ["AOPass", "AO_METHODS", "VectorAO", "StandardSSAO", "CrytekAO", "HBAO", "AlchemyAO", "GTAO", "VBAO"]
