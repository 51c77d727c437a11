"""Verification of a written asset: render it, compare with the exact reference, report.

The entry point is :func:`rockdove.verify.verification.verify` (the build's ``verify`` stage, ``rockdove verify``
and :func:`rockdove.api.verify` all call it): it keeps its renders as items of the stage cache
(:mod:`rockdove.cache`), renders the views (:mod:`~rockdove.verify.run`) and the hosts
(:mod:`~rockdove.verify.host_check`), and hands them to :func:`rockdove.verify.verdict.combine` for the report.
It is not re-exported here: a package's ``__init__`` is part of every cache key that reaches the package.

Reads the asset back through :mod:`rockdove.render` and :mod:`rockdove.hosts`, and never imports the build. Heavy
libraries (pxr, trimesh, pyrender, matplotlib) are imported inside the functions that use them."""
