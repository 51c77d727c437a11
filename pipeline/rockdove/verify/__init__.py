"""Verification of a written asset: render it, compare with the exact reference, report.

Reads the asset back through :mod:`rockdove.render` (scene, views, GL) and the host adapters of
:mod:`rockdove.hosts`, and never imports the build: ``config -> physics -> LUT / geometry -> USD -> render ->
hosts -> verify -> build``. Heavy libraries (pxr, trimesh, pyrender, matplotlib) are imported inside the
functions that use them, so importing this package is cheap.
"""
