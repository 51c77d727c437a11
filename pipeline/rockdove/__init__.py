"""rockdove: a USD asset of a rock dove whose neck feathers shimmer by thin-film interference.

Importing this package is cheap and needs no display: heavy or display-bound libraries (pxr, pyrender,
MaterialX, OpenGL) are imported inside the functions that use them."""

__version__ = "0.1.0"
