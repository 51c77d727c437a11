"""The incremental build: stages keyed by content hash and cached (``graph``), the real stage functions that
wire the pipeline's modules (``stages``), and atomic publishing with a lock and a marker (``publish``)."""
