"""Benchmarks behind ``rockdove bench``: one module per topic (``lut``, ``geometry``, ``build``, ``render``),
each exposing ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``. Timings are medians of repeats and
speed goals are ratios measured in the same run, because these machines are shared and noisy."""

TOPICS = ("lut", "geometry", "render", "build", "sweep", "memory", "viewer")
