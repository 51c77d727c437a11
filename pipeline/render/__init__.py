"""Verification renders: read the written USD back (:mod:`.scene`), cameras and lights (:mod:`.views`), the
GLSL/pyrender offscreen renderer (:mod:`.gl`), PNG helpers (:mod:`.images`); the CPU reference, comparison and
report live beside them. Heavy libraries (pxr, pyrender, OpenGL) are imported inside the functions that use
them, so importing this package is cheap."""
