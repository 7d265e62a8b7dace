# Sagitta workbench, non-GUI part: registers the Bézier patch importer (File → Open / Import).
import FreeCAD

FreeCAD.addImportType("Sagitta Bézier patches (*.bpt *.rib)", "SagittaImport")
