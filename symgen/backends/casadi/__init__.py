"""The derived model as CasADi Functions (``functions``), stored in and verified from the model
cache (``store``); ``pipeline.compile_scene`` derives once per structure and reuses the cache."""
