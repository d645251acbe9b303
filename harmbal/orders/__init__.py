"""The order-domain stage, on plain arrays: FFT phasors and the co/counter
split, order phasors per cylinder by the shift theorem, crank stars."""
