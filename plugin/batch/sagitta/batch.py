"""`sagitta.batch.run(...)`: the batch's Python API under the name issue 19 gives it; see sagitta_batch."""
from sagitta_batch import expand_inputs, run

__all__ = ["run", "expand_inputs"]
