"""Process: what the tool does to the sheet, and the declared process every stage receives.

Modules: `description` (the process as data: material, thickness, tool, friction, force model and history),
`materials` (sheet materials, each number with its source: the shipped library and name look-up), `hardening`
(a material's hardening law), `material_file` (reading a materials file, the library's or a user's),
`process_file` (the process a user declares in a process file, and its record in runs and model files),
`force_field` (the `ForceField` base every force model implements), `force_models` (the registry of force
models: name -> builder), `field` (the groove's per-pass table force field, on the formed profile of
`formed_profile` and the per-pass tables of `pass_tables`), `aerens` (the published steady axial force with the
scallop height), `isf_force` (the height-map ISF model on `heightmap`, with the sliding direction of `sliding`),
its constants `isf_params` and its fit to the groove `isf_calibration`, `learned_force` (that model with membrane
terms learned from a cell's F/T stream), `tool_friction` (the tool's
sliding friction at reversals), `forces` (loading FE histories with a declared symmetry) and `fe_history` (the
stand-in generator), `path` (the groove U_ID, pass labels), `shapes` (cones, pyramids), `gcode` (CAM programs),
`placement` (the sheet in the robot base, reach), `springback` (the part after unclamping, a rigid machine's
forming), `part_surface` and `part_bottom` (the formed part as a surface: target, design, scan).

Takes path parameters, an FE export, the process and the materials; gives the commanded path U_ID and the force on the tool at
any position.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "Process": "twin.process.description",
    "Material": "twin.process.materials",
    "Source": "twin.process.materials",
    "MaterialLibrary": "twin.process.materials",
    "material": "twin.process.materials",
    "shipped_materials": "twin.process.materials",
    "shipped_library": "twin.process.materials",
    "HardeningLaw": "twin.process.hardening",
    "read_material_file": "twin.process.material_file",
    "read_material_library": "twin.process.material_file",
    "ProcessDeclaration": "twin.process.process_file",
    "read_process_file": "twin.process.process_file",
    "read_process_declaration": "twin.process.process_file",
    "process_for": "twin.process.process_file",
    "process_record": "twin.process.process_file",
    "process_from_record": "twin.process.process_file",
    "ForceField": "twin.process.force_field",
    "FieldState": "twin.process.force_field",
    "ForceModel": "twin.process.force_models",
    "FORCE_MODELS": "twin.process.force_models",
    "register_force_model": "twin.process.force_models",
    "unregister_force_model": "twin.process.force_models",
    "force_model": "twin.process.force_models",
    "build_force_field": "twin.process.force_models",
    "auto_force_model": "twin.process.force_models",
    "SheetForceField": "twin.process.field",
    "IsfForceField": "twin.process.isf_force",
    "IsfForceParams": "twin.process.isf_params",
    "params_for": "twin.process.isf_params",
    "steady_fz_n": "twin.process.isf_params",
    "aerens_fz_n": "twin.process.aerens",
    "scallop_height_m": "twin.process.aerens",
    "IsfFit": "twin.process.isf_calibration",
    "calibrate_isf": "twin.process.isf_calibration",
    "HeightMap": "twin.process.heightmap",
    "SlidingFriction": "twin.process.tool_friction",
    "ForceHistory": "twin.process.forces",
    "load_force_history": "twin.process.forces",
    "default_force_history": "twin.process.forces",
    "ToolPath": "twin.process.path",
    "GrooveSpec": "twin.process.path",
    "groove_path": "twin.process.path",
    "label_passes": "twin.process.path",
    "write_path_csv": "twin.process.path",
    "PartSpec": "twin.process.shapes",
    "part_path": "twin.process.shapes",
    "parse_gcode": "twin.process.gcode",
    "read_gcode": "twin.process.gcode",
    "write_gcode": "twin.process.gcode",
    "Placement": "twin.process.placement",
    "ReachReport": "twin.process.placement",
    "check_reach": "twin.process.placement",
    "form_rigidly": "twin.process.springback",
    "with_floating_bottom": "twin.process.part_bottom",
    "formed_surface": "twin.process.part_surface",
    "heightmap_mesh": "twin.process.part_surface",
    "surface_points": "twin.process.part_surface",
    "target_part_surface": "twin.process.part_surface",
    "design_part_surface": "twin.process.part_surface",
})
