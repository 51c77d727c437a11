"""The renderer: read the written USD back for drawing (:mod:`.scene`), cameras and lights (:mod:`.views`), the
GLSL/pyrender offscreen renderer (:mod:`.gl`), PNG helpers (:mod:`.images`). Verification (the exact reference,
comparison, report) builds on it in :mod:`rockdove.verify`; nothing here imports hosts, verification or the
build. Heavy libraries (pxr, pyrender, OpenGL) are imported inside the functions that use them, so importing
this package is cheap."""
