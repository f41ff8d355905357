"""The contract between the derivation and its consumers: the typed records of a derived model
(coordinates, multipliers, parameters; each owns its symbol, its value accessor and its LaTeX
name) that every backend and runner reads, never re-deriving meaning from symbol names."""
