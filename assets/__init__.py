"""Data package: the files in this folder ship inside rockdove (found with rockdove.resources)."""
