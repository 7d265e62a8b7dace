"""The `sagitta` Python namespace of issue 19: `sagitta.batch.run(...)` (an alias of sagitta_batch.run).
The compiled FreeCAD/pybind11 module is `_sagitta`, so this name clashes with nothing."""
