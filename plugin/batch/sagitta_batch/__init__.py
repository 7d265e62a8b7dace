"""sagitta batch: validate, tessellate or fit a library of CAD parts and patch models on Dask.distributed, one
isolated child process per file, results in SQLite (see docs/BATCH.md)."""
from .engine import expand_inputs, run

__all__ = ["run", "expand_inputs"]
