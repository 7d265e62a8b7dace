# Sagitta workbench, GUI part: the workbench with its toolbar and menu.
import os

import FreeCADGui


class SagittaWorkbench(FreeCADGui.Workbench):
    MenuText = "Sagitta"
    ToolTip = "Tessellate Bézier and B-spline faces and certify the distance to the exact surface"

    def __init__(self):
        import SagittaCore  # noqa: F401  (locates the workbench folder)
        self.__class__.Icon = os.path.join(os.path.dirname(SagittaCore.__file__), "icons", "Sagitta_Workbench.svg")

    def Initialize(self):
        import SagittaGui
        SagittaGui.register()
        self.appendToolbar("Sagitta", SagittaGui.COMMANDS)
        self.appendMenu("Sagitta", SagittaGui.COMMANDS)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(SagittaWorkbench())
