"""Judging the rendering: ray-traced reference, compare, metrics, bench."""
