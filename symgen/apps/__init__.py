"""Applications on top of the numerics: studies (accuracy against CPU time), the effects
report, the seed's reproduction, parameter sweeps, plots, animations and the golden files."""
