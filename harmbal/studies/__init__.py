"""Studies over many variants of a scene: design-space sweeps and production-tolerance Monte Carlo
(after the balancer design, which they repeat per variant)."""
