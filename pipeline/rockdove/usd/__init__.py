"""The USD asset: layers (:mod:`.stage`), materials, textures, schema, usdz and the validator. pxr and MaterialX
are imported inside the functions that use them, so importing this package is cheap."""
