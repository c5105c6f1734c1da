"""mrcheck: CAD over a calibrated photo, with vector-based SSAO."""

__version__ = "0.1.0"
