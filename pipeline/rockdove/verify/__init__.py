"""Verification of a written asset: render it, compare with the exact reference, report.

Reads the asset back through :mod:`rockdove.render` (scene, views, GL) and the host adapters of
:mod:`rockdove.hosts`, and never imports the build: ``config -> physics -> LUT / geometry -> USD -> render ->
hosts -> verify -> build``. Modules: :mod:`.run` (``rockdove verify``: orchestration), :mod:`.inputs` (the
scene, the views and their digests), :mod:`.rays` and :mod:`.reference_image` (the CPU reference: primary ray
casts, then per-pixel shading with the exact film colour of :func:`rockdove.lut.reference.reference_colour`),
:mod:`.compare` (dE maps, metrics, hue classes), :mod:`.boundary` (shape of the green/purple boundary),
:mod:`.host_check` (each host against the reference of its lobe), :mod:`.verdict` (pass/fail and
report.json), :mod:`.report` (figures and report.html), :mod:`.provenance` (asset hash, configuration, library
versions, validation). Heavy libraries (pxr, trimesh, pyrender, matplotlib) are imported inside the functions
that use them, so importing this package is cheap.
"""
