"""Screen-space ambient occlusion passes, one module per method.

* :mod:`.vector` — the vector-based method of Scheer & Keutel (D2)
* :mod:`.ssao` — standard normal-oriented hemisphere SSAO (D3)
"""

from .base import AOPass
from .ssao import StandardSSAO
from .vector import VectorAO

AO_METHODS = {"vector": VectorAO, "ssao": StandardSSAO}

__all__ = ["AOPass", "AO_METHODS", "VectorAO", "StandardSSAO"]
