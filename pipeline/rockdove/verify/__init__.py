"""Verification of a written asset: render it, compare with the exact reference, report.

Reads the asset back through :mod:`rockdove.render` and :mod:`rockdove.hosts`, and never imports the build. Heavy
libraries (pxr, trimesh, pyrender, matplotlib) are imported inside the functions that use them.
"""
