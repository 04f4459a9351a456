"""Process: what the tool does to the sheet, and the declared process every stage receives.

Split by concept: `description` (the process as data: material, thickness, tool, friction, force model and
history) `process_file` (the process a user declares in a process file, and its record in runs and model
files) and `cell_file` (a user's cell declared once: robot, tool, sheet placement and process) here; `toolpath/` (the groove, cones and pyramids, G-code, placement and reach), `material/` (the
library, hardening laws, materials files), `force/` (the `ForceField` seam, its registry and the force models),
`fe/` (FE force histories with a declared symmetry, and the stand-in generator) and `part/` (the formed sheet and
part: height map, profile, surface, springback).

Takes path parameters, an FE export, the process and the materials; gives the commanded path U_ID and the force on the tool at
any position.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "Process": "twin.process.description",
    "Material": "twin.process.material.library",
    "Source": "twin.process.material.library",
    "MaterialLibrary": "twin.process.material.library",
    "material": "twin.process.material.file",
    "shipped_materials": "twin.process.material.file",
    "shipped_library": "twin.process.material.file",
    "HardeningLaw": "twin.process.material.hardening",
    "read_material_file": "twin.process.material.file",
    "read_material_library": "twin.process.material.file",
    "ProcessDeclaration": "twin.process.process_file",
    "read_process_file": "twin.process.process_file",
    "read_process_declaration": "twin.process.process_file",
    "process_for": "twin.process.process_file",
    "process_record": "twin.process.process_file",
    "process_from_record": "twin.process.process_file",
    "ForceField": "twin.process.force.base",
    "FieldState": "twin.process.force.base",
    "ForceModel": "twin.process.force.registry",
    "FORCE_MODELS": "twin.process.force.registry",
    "register_force_model": "twin.process.force.registry",
    "unregister_force_model": "twin.process.force.registry",
    "force_model": "twin.process.force.registry",
    "build_force_field": "twin.process.force.registry",
    "auto_force_model": "twin.process.force.registry",
    "SheetForceField": "twin.process.force.table",
    "IsfForceField": "twin.process.force.isf",
    "IsfForceParams": "twin.process.force.isf_params",
    "params_for": "twin.process.force.isf_params",
    "steady_fz_n": "twin.process.force.isf_params",
    "aerens_fz_n": "twin.process.force.aerens",
    "scallop_height_m": "twin.process.force.aerens",
    "IsfFit": "twin.process.force.isf_calibration",
    "calibrate_isf": "twin.process.force.isf_calibration",
    "HeightMap": "twin.process.part.heightmap",
    "SlidingFriction": "twin.process.force.tool_friction",
    "ForceHistory": "twin.process.fe.load",
    "load_force_history": "twin.process.fe.load",
    "default_force_history": "twin.process.fe.load",
    "ToolPath": "twin.process.toolpath.groove",
    "GrooveSpec": "twin.process.toolpath.groove",
    "groove_path": "twin.process.toolpath.groove",
    "label_passes": "twin.process.toolpath.groove",
    "PartSpec": "twin.process.toolpath.shapes",
    "part_path": "twin.process.toolpath.shapes",
    "parse_gcode": "twin.process.toolpath.gcode",
    "read_gcode": "twin.process.toolpath.gcode",
    "write_gcode": "twin.process.toolpath.gcode_write",
    "Placement": "twin.process.toolpath.placement",
    "ReachReport": "twin.process.toolpath.placement",
    "check_reach": "twin.process.toolpath.placement",
    "form_rigidly": "twin.process.part.springback",
    "with_floating_bottom": "twin.process.part.bottom",
    "formed_surface": "twin.process.part.surface",
    "heightmap_mesh": "twin.process.part.surface",
    "surface_points": "twin.process.part.surface",
    "target_part_surface": "twin.process.part.surface",
    "design_part_surface": "twin.process.part.surface",
})
