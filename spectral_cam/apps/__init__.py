"""Applications on top of the simulation core: stress studies, validation, datasets, benchmarks."""
