"""The USD asset: layers, meshes, variants (:mod:`.stage`), material networks (:mod:`.material`), textures on
disk (:mod:`.textures_io`), the RockDoveThinFilmAPI schema (:mod:`.schema`), usdz (:mod:`.usdz`) and the
validator (:mod:`.validate`).

pxr and MaterialX are imported inside the functions that use them, so importing this package is cheap.
"""
