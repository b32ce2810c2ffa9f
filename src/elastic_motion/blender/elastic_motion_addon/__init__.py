"""elastic-motion for Blender: blend, loop and compare the actions of armatures.

A panel in the 3D view's sidebar (N panel, tab "elastic-motion"). Each operator exports the
selected armatures' actions to BVH, runs the ``elastic-motion`` command of the user's
environment in a subprocess (its path is set in this add-on's preferences; Blender's Python
has no numpy or numba, so the add-on never imports elastic-motion), imports the result as a
new action on the active armature and shows the JSON report in the panel (the whole report
in the text block "elastic-motion report"). Errors of the command appear as Blender reports.

Packed by ``elastic-motion blender-addon -o elastic_motion_addon.zip``; install the zip with
Edit > Preferences > Add-ons > Install.
"""

bl_info = {
    "name": "elastic-motion",
    "author": "elastic-motion developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D View > Sidebar > elastic-motion",
    "description": "Blend, loop and compare armature actions by elastic shape analysis (elastic-motion)",
    "category": "Animation",
}


# The operators import bpy, which exists only inside Blender: they are loaded when Blender
# registers the add-on (the command lines of runner.py are tested without Blender).


def register():
    from . import ops

    ops.register()


def unregister():
    from . import ops

    ops.unregister()
